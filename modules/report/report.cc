#include "report/report.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <map>
#include <sstream>

#include "brdf/brdf.h"
#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/timer.h"
#include "evaluate/evaluate.h"
#include "relight/display.h"
#include "relight/relight.h"
#include "report/charts.h"
#include "report/html.h"

namespace relight {
namespace fs = std::filesystem;

namespace {

bool IsFile(const std::string& path) { return !path.empty() && fs::is_regular_file(path); }

std::string Hex(const Eigen::Vector3d& linear_rgb) {
  char buf[8];
  int v[3];
  for (int c = 0; c < 3; ++c) v[c] = int(std::lround(255 * SrgbEncode(std::clamp(linear_rgb[c], 0.0, 1.0))));
  std::snprintf(buf, sizeof(buf), "#%02x%02x%02x", v[0], v[1], v[2]);
  return buf;
}

std::string Swatch(const Eigen::Vector3d& linear_rgb) {
  return "<span class=\"swatch\" style=\"background:" + Hex(linear_rgb) + "\"></span>";
}

double Num(const Json& j, const std::string& key, double fallback = NAN) {
  return j.contains(key) && j[key].is_number() ? j[key].get<double>() : fallback;
}

std::string CsvNumber(double v) {
  if (!std::isfinite(v)) return "NaN";
  std::ostringstream s;
  s.precision(8);
  s << v;
  return s.str();
}

// Indices of at most `max` items evenly spread over n (all when max is 0).
std::vector<size_t> Spread(size_t n, int max) {
  std::vector<size_t> out;
  if (max <= 0 || size_t(max) >= n) {
    for (size_t i = 0; i < n; ++i) out.push_back(i);
    return out;
  }
  for (int k = 0; k < max; ++k) {
    const size_t i = std::min(n - 1, size_t(std::floor((k + 0.5) * n / max)));
    if (out.empty() || out.back() != i) out.push_back(i);
  }
  return out;
}

// Short definitions shown beside the headline metrics (the full ones: docs/METRICS.md).
const std::map<std::string, std::string>& Definitions() {
  static const std::map<std::string, std::string> d = {
      {"relight_psnr_db",
       "Held-out views relit under held-out environment maps against the ground-truth renders: scale-invariant "
       "HDR-PSNR inside the object mask (one least-squares scale per channel; peak = 99th percentile of the "
       "reference), mean over renders."},
      {"shadow_contrast_error",
       "Held-out views under held-out skies with a known sun: the ratio of mean luminance where the sun reaches "
       "the true surface to where it does not (regions ray-cast on the true geometry, 2 px from their edges), "
       "relit against ground truth: |relit ratio / true ratio &minus; 1|, mean over renders (0: the truth's "
       "contrast; 0.2: shadows 20 % too light or too dark, e.g. shading baked into the albedo or a blurred sun)."},
      {"rerender_psnr_db",
       "Input photos re-rendered under their recovered environment maps against the linear photos, same PSNR, over "
       "unclipped pixels of observed vertices; mean over photos."},
      {"rerender_rmse",
       "Relative RMSE of the same comparison, sqrt(&Sigma;(sE&minus;R)&sup2; / &Sigma;R&sup2;), mean over photos."},
      {"envmap_rel_error",
       "Recovered against true environment maps on the recovered map's octahedral grid, per-channel scaled, "
       "solid-angle weighted relative L2 error (0 perfect, 1 no information); mean over photos."},
      {"light_dir_error_deg",
       "Angle between the recovered map's brightest lobe and the sun (photos under a sky), else the true map's "
       "brightest lobe or the known light (DiLiGenT); median over photos."},
      {"albedo_psnr_db",
       "Per-vertex diffuse albedo against the true albedo (closest true surface point), per-channel scaled, peak 1; "
       "the object's observed vertices (a reconstructed ground is scored apart)."},
      {"loo_psnr_db",
       "Leave-one-photo-out: each scored photo rendered with reflectance fitted without it (only its environment "
       "map fitted to it), same PSNR as re-renderings; mean over scored photos."}};
  return d;
}

const char* kStyle = R"CSS(
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1500px; padding: 0 1em; color: #222; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 2em; }
nav a { margin-right: 1em; } .meta { color: #666; }
table { border-collapse: collapse; margin: 0.5em 0 1em; } th, td { border: 1px solid #ddd; padding: 4px 8px; vertical-align: top; }
th { background: #f4f4f4; text-align: left; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
table.images td { border: none; padding: 2px; } table.images th { background: none; border: none; }
figure { display: inline-block; margin: 4px; vertical-align: top; } figcaption { font-size: 0.85em; color: #444; max-width: 100%; }
img.pixelated { image-rendering: pixelated; } .swatch { display: inline-block; width: 1.2em; height: 1.2em; border: 1px solid #888; vertical-align: middle; margin-right: 4px; }
.na { color: #999; } .note { color: #8a5a00; } #selfcheck { font-size: 0.85em; color: #666; }
.def { font-size: 0.85em; color: #555; max-width: 60em; }
)CSS";

const char* kSelfCheck = R"JS(
window.relightErrors = [];
window.addEventListener('error', function (e) {
  if (e.target && e.target !== window && e.target.tagName) return;  // resource errors: counted as broken images
  window.relightErrors.push(String(e.message || 'error'));
}, true);
window.addEventListener('load', function () {
  var images = document.images, broken = [];
  for (var i = 0; i < images.length; ++i)
    if (!images[i].complete || images[i].naturalWidth === 0) broken.push(images[i].getAttribute('src'));
  var s = document.getElementById('selfcheck');
  var ok = broken.length === 0 && window.relightErrors.length === 0;
  s.setAttribute('data-images', String(images.length));
  s.setAttribute('data-broken', String(broken.length));
  s.setAttribute('data-js-errors', String(window.relightErrors.length));
  s.setAttribute('data-status', ok ? 'ok' : 'fail');
  s.textContent = 'Page check: ' + images.length + ' images, ' + broken.length + ' broken' +
      (broken.length ? ' (' + broken.join(', ') + ')' : '') + ', ' + window.relightErrors.length + ' script errors.';
});
)JS";

// Everything the page is built from.
class ReportBuilder {
 public:
  ReportBuilder(const ReportOptions& o, const std::map<std::string, std::string>& inputs, const std::string& out)
      : o_(o), inputs_(inputs), out_(out) {}

  std::string Input(const std::string& stage) const {
    auto it = inputs_.find(stage);
    return it == inputs_.end() ? "" : it->second;
  }

  // Copies `src` (absolute) to images/<dst>; returns the page's relative path, or "" (with a note) when missing.
  std::string Copy(const std::string& src, const std::string& dst) {
    if (!IsFile(src)) {
      summary_.notes.push_back("missing image " + src);
      return "";
    }
    const std::string rel = "images/" + dst;
    EnsureDir(fs::path(JoinPath(out_, rel)).parent_path().string());
    WriteFileAtomic(JoinPath(out_, rel), ReadFileToString(src));
    ++summary_.images;
    return rel;
  }
  std::string Fig(const std::string& src, const std::string& dst, const std::string& caption, int width = -1,
                  const std::string& css = "") {
    const std::string rel = Copy(src, dst);
    return rel.empty() ? "<span class=\"na\">(missing)</span>"
                       : html::Figure(rel, caption, width < 0 ? o_.tile_px : width, css);
  }
  std::string Chart(const std::string& name, const std::vector<std::string>& columns,
                    const std::vector<std::vector<std::string>>& rows, const std::string& body, int w = 640,
                    int h = 360) {
    const std::string dir = JoinPath(out_, "charts");
    EnsureDir(dir);
    const ChartFiles f = WriteChart(dir, name, columns, rows, body, o_.charts == "gnuplot", w, h);
    std::string links = "<p class=\"def\">Data: <a href=\"charts/" + f.csv + "\">" + f.csv +
                        "</a>, script: <a href=\"charts/" + f.script + "\">" + f.script + "</a></p>";
    if (!f.svg.empty()) {
      ++summary_.charts;
      return html::Img("charts/" + f.svg, name, w) + links;
    }
    if (!f.error.empty()) summary_.notes.push_back("chart " + name + ": " + f.error);
    return links;
  }

  void Build() {
    Timer timer;
    // Inputs.
    const std::string evaluate = Input("evaluate"), relight_dir = Input("relight"), inverse = Input("inverse");
    if (!evaluate.empty()) {
      metrics_ = ReadJsonFile(JoinPath(evaluate, "metrics.json"));
      if (IsFile(JoinPath(evaluate, "figures.json"))) figures_ = ReadJsonFile(JoinPath(evaluate, "figures.json"));
      WriteFileAtomic(JoinPath(out_, "metrics.json"), ReadFileToString(JoinPath(evaluate, "metrics.json")));
    } else {
      summary_.notes.push_back("the evaluate stage did not run: no metrics");
    }
    if (!relight_dir.empty())
      renders_ = ReadRenderIndex(relight_dir, &turntable_gif_, &exported_);
    else
      summary_.notes.push_back("the relight stage did not run: no renders");

    std::ostringstream body;
    Sections(body);
    std::ostringstream page;
    std::string title = o_.title;
    if (title.empty()) {
      const fs::path p = fs::path(out_);
      const bool in_cache = p.parent_path().parent_path().filename() == "cache";
      title = "relight report: " +
              (in_cache ? p.parent_path().parent_path().parent_path().filename().string() : p.filename().string());
    }
    const std::time_t now = std::time(nullptr);
    char date[64];
    std::strftime(date, sizeof(date), "%Y-%m-%d %H:%M", std::localtime(&now));
    page << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" << html::Escape(title)
         << "</title>\n<style>" << kStyle << "</style>\n<script>" << kSelfCheck << "</script>\n</head>\n<body>\n<h1>"
         << html::Escape(title) << "</h1>\n<p class=\"meta\">Written " << date
         << " by the report stage of relight (Haber et al., CVPR 2009). Metric definitions: docs/METRICS.md; "
            "numbers: <a href=\"metrics.json\">metrics.json</a>.</p>\n<nav>";
    for (const auto& [id, name] : nav_) page << "<a href=\"#" << id << "\">" << html::Escape(name) << "</a>";
    page << "</nav>\n<p id=\"selfcheck\" data-status=\"pending\">Page check: pending (needs JavaScript).</p>\n"
         << body.str();
    if (!summary_.notes.empty()) {
      page << "<h2 id=\"notes\">Notes</h2><ul>";
      for (const auto& n : summary_.notes) page << "<li class=\"note\">" << html::Escape(n) << "</li>";
      page << "</ul>\n";
    }
    page << "</body>\n</html>\n";
    WriteFileAtomic(JoinPath(out_, "index.html"), page.str());
    summary_.seconds = timer.Seconds();
  }

  ReportSummary summary() const { return summary_; }

 private:
  void Section(std::ostringstream& s, const std::string& id, const std::string& name) {
    nav_.emplace_back(id, name);
    s << "<h2 id=\"" << id << "\">" << html::Escape(name) << "</h2>\n";
  }

  std::vector<const RenderRecord*> Renders(const std::string& kind) const {
    std::vector<const RenderRecord*> out;
    for (const auto& r : renders_)
      if (r.kind == kind) out.push_back(&r);
    return out;
  }

  std::string EvalFig(const Json& entry, const std::string& key, const std::string& caption, int width = -1,
                      const std::string& css = "") {
    if (!entry.contains(key)) return "<span class=\"na\">n/a</span>";
    const std::string rel = entry[key].get<std::string>();
    return Fig(JoinPath(Input("evaluate"), rel), "evaluate/" + rel.substr(rel.find('/') + 1), caption, width, css);
  }

  std::string RelightFig(const RenderRecord& r, const std::string& caption, int width = -1) {
    return Fig(JoinPath(Input("relight"), r.png), "relight/" + r.png.substr(r.png.find('/') + 1), caption, width);
  }

  void Sections(std::ostringstream& s) {
    MetricsSection(s);
    GeometrySection(s);
    PhotosSection(s);
    EnvMapsSection(s);
    MaterialsSection(s);
    HeldOutSection(s);
    NewLightSection(s);
    TurntableSection(s);
    ExportSection(s);
    ConvergenceSection(s);
    LeaveOneOutSection(s);
    TimingsSection(s);
  }

  void MetricsSection(std::ostringstream& s) {
    Section(s, "metrics", "Metrics");
    if (metrics_.is_null()) {
      s << "<p class=\"na\">No metrics: the evaluate stage did not run.</p>\n";
      return;
    }
    std::vector<std::vector<std::string>> rows;
    for (const auto& key : HeadlineMetricKeys()) {
      std::string value;
      if (metrics_.contains(key) && metrics_[key].is_number()) {
        value =
            html::Number(metrics_[key].get<double>(),
                         key.find("rmse") != std::string::npos || key.find("rel_error") != std::string::npos ? 4 : 2);
      } else {
        std::string reason = "not available";
        if (metrics_.contains("not_available") && metrics_["not_available"].contains(key))
          reason = metrics_["not_available"][key].get<std::string>();
        value = "<span class=\"na\">n/a: " + html::Escape(reason) + "</span>";
      }
      if (key == "loo_psnr_db" && metrics_.contains("leave_one_out") &&
          std::isfinite(Num(metrics_["leave_one_out"], "rerender_psnr_db"))) {
        value += " <span class=\"def\">(the same photos re-rendered: " +
                 html::Number(Num(metrics_["leave_one_out"], "rerender_psnr_db"), 2) + ")</span>";
      }
      rows.push_back({"<code>" + key + "</code>", value, "<span class=\"def\">" + Definitions().at(key) + "</span>"});
    }
    s << html::Table({"metric", "value", "definition"}, rows);
    if (metrics_.contains("cameras")) {
      const Json& c = metrics_["cameras"];
      s << "<h3>Cameras against the ground truth</h3>"
        << html::Table({"matched", "missing", "median rotation error [deg]", "max rotation error [deg]",
                        "median centre error [% of scene radius]"},
                       {{std::to_string(c.value("matched", 0)), std::to_string(c.value("missing", 0)),
                         html::Number(Num(c, "median_rotation_deg"), 3), html::Number(Num(c, "max_rotation_deg"), 3),
                         html::Number(100 * Num(c, "median_center_error_relative"), 2)}});
    }
    if (metrics_.contains("mesh")) {
      const Json& m = metrics_["mesh"];
      s << "<h3>Mesh against the ground truth</h3>"
        << html::Table({"source", "Chamfer [% of diagonal]", "accuracy mean [%]", "completeness mean [%]",
                        "accuracy p90 [%]", "completeness p90 [%]"},
                       {{html::Escape(m.value("source", "")), html::Number(100 * Num(m, "chamfer_relative"), 3),
                         html::Number(100 * Num(m, "accuracy_mean_relative"), 3),
                         html::Number(100 * Num(m, "completeness_mean_relative"), 3),
                         html::Number(100 * Num(m, "accuracy_p90_relative"), 3),
                         html::Number(100 * Num(m, "completeness_p90_relative"), 3)}});
    }
    if (metrics_.contains("directional_lights")) {
      const Json& d = metrics_["directional_lights"];
      const auto p = d.value("pearson_rgb", std::vector<double>{NAN, NAN, NAN});
      s << "<h3>Known directional lights (DiLiGenT)</h3>"
        << html::Table({"photos", "median angle error [deg]", "p90 angle error [deg]", "Pearson R, G, B",
                        "relative intensity RMSE"},
                       {{std::to_string(d.contains("photos") ? d["photos"].size() : 0),
                         html::Number(Num(d, "median_angle_deg"), 2), html::Number(Num(d, "p90_angle_deg"), 2),
                         html::Number(p[0], 3) + ", " + html::Number(p[1], 3) + ", " + html::Number(p[2], 3),
                         html::Number(Num(d, "relative_intensity_rmse"), 3)}});
    }
    if (metrics_.contains("frame")) {
      s << "<p class=\"def\">Model frame against the ground truth: "
        << html::Escape(metrics_["frame"].value("method", "none")) << ".</p>\n";
    }
  }

  // Structure from motion (which photos registered, how sure) and the geometry seen from the photos' cameras.
  void GeometrySection(std::ostringstream& s) {
    const std::string sfm = Input("sfm"), mesh = Input("mesh"), ingest = Input("ingest");
    if (sfm.empty() && mesh.empty()) return;
    Section(s, "geometry", "Cameras and geometry");
    if (!sfm.empty() && IsFile(JoinPath(sfm, "sfm_summary.json"))) {
      const Json j = ReadJsonFile(JoinPath(sfm, "sfm_summary.json"));
      const std::string consensus = j.value("consensus", "");
      const std::map<std::string, std::string> meaning = {
          {"agreed", "two mapper runs from different first pairs placed the cameras the same way"},
          {"consistent", "the photo pairs' own matches agree with the cameras; no other consistent run disagrees"},
          {"unchecked", "only one mapper run built a model and too few photo pairs to check it"},
          {"disagreed", "mapper runs from different first pairs disagree: the cameras may be wrong"},
          {"inconsistent", "the model contradicts many of its own photo pairs: the cameras may be wrong"}};
      s << "<p>" << j.value("num_registered", 0) << " of " << j.value("num_photos", 0) << " photos registered ("
        << html::Escape(j.value("mode", "")) << " mode";
      if (meaning.count(consensus)) s << "; " << html::Escape(meaning.at(consensus));
      s << ").</p>\n";
      if (j.contains("mapper_runs") && !j["mapper_runs"].empty()) {
        std::vector<std::vector<std::string>> rows;
        for (const Json& r : j["mapper_runs"]) {
          rows.push_back({html::Escape(r.value("first_pair", "")), std::to_string(r.value("num_registered", 0)),
                          std::to_string(r.value("photo_pairs_agreeing", 0)) + " of " +
                              std::to_string(r.value("photo_pairs_checked", 0)),
                          r.value("kept", false) ? "kept" : ""});
        }
        s << html::Table({"mapper run: first pair", "photos", "photo pairs that agree", ""}, rows);
      }
      std::vector<std::vector<std::string>> dropped;
      for (const Json& p : j.value("photos", Json::array())) {
        if (!p.value("registered", false)) {
          dropped.push_back({html::Escape(p.value("name", "")), html::Escape(p.value("reason", ""))});
        } else if (p.value("unstable", false)) {
          dropped.push_back({html::Escape(p.value("name", "")),
                             "registered, but placed differently by an independent run: its camera may be wrong"});
        }
      }
      if (!dropped.empty()) s << html::Table({"photo", "not registered because"}, dropped);
    }
    if (mesh.empty() || !IsFile(JoinPath(mesh, "views.json"))) return;
    s << "<p class=\"def\">The cleaned mesh (grey clay) and the fused multi-view stereo points seen from the "
         "photos' cameras: where the mesh departs from the photo, the geometry is wrong.</p>\n";
    std::map<std::string, std::string> photo_files;
    if (!ingest.empty() && IsFile(JoinPath(ingest, "manifest.json"))) {
      for (const Json& p : ReadJsonFile(JoinPath(ingest, "manifest.json")).value("photos", Json::array())) {
        if (!p.value("linear", false)) photo_files[p.value("name", "")] = JoinPath(ingest, p.value("file", ""));
      }
    }
    std::vector<std::vector<std::string>> rows;
    for (const Json& v : ReadJsonFile(JoinPath(mesh, "views.json")).value("views", Json::array())) {
      const std::string name = v.value("photo", "");
      auto fig = [&](const std::string& key, const std::string& what) {
        if (!v.contains(key)) return std::string("<span class=\"na\">n/a</span>");
        const std::string rel = v[key].get<std::string>();
        return Fig(JoinPath(mesh, rel), "geometry/" + fs::path(rel).filename().string(), name + ": " + what);
      };
      const std::string photo = photo_files.count(name) ? Fig(photo_files[name],
                                                              "geometry/" + fs::path(name).stem().string() + "_photo" +
                                                                  fs::path(photo_files[name]).extension().string(),
                                                              name + ": photo")
                                                        : "<span class=\"na\">n/a</span>";
      rows.push_back({html::Escape(name), photo, fig("points", "fused points"), fig("mesh", "mesh")});
    }
    s << html::Table({"photo", "photo", "fused MVS points", "cleaned mesh"}, rows, "images");
  }

  void PhotosSection(std::ostringstream& s) {
    Section(s, "photos", "Photos and re-renderings");
    s << "<p class=\"def\">Each input photo (linear, tone-mapped) beside the recovered model rendered from its camera "
         "under its recovered environment map (scaled per channel like the metric, same exposure), and the per-pixel "
         "error relative to the PSNR peak over the compared pixels (others grey).</p>\n";
    const Json list = figures_.contains("rerender") ? figures_["rerender"] : Json::array();
    if (!list.empty()) {
      s << HeatMapLegend();
      std::vector<std::vector<std::string>> rows;
      for (size_t i : Spread(list.size(), o_.max_photos)) {
        const Json& e = list[i];
        const std::string name = e.value("name", "");
        rows.push_back({html::Escape(name), EvalFig(e, "photo", name + ": photo"),
                        EvalFig(e, "rerender", name + ": re-rendering"), EvalFig(e, "error", name + ": error"),
                        html::Number(Num(e, "psnr_db"), 2)});
      }
      s << html::Table({"photo", "linear photo", "re-rendering", "error", "PSNR [dB]"}, rows, "images");
      return;
    }
    const auto rr = Renders("rerender");
    if (rr.empty()) {
      s << "<p class=\"na\">No re-renderings (relight.rerender off or the relight stage did not run).</p>\n";
      return;
    }
    for (size_t i : Spread(rr.size(), o_.max_photos)) s << RelightFig(*rr[i], rr[i]->view + ": re-rendering");
  }

  std::string HeatMapLegend() {
    const double max = figures_.value("heatmap_max", 0.2);
    Image ramp(256, 14, 1);
    for (int y = 0; y < ramp.height; ++y)
      for (int x = 0; x < ramp.width; ++x) ramp.at(x, y) = float(max * x / (ramp.width - 1));
    EnsureDir(JoinPath(out_, "images"));
    WritePng(JoinPath(out_, "images/heatmap_legend.png"), HeatMap(ramp, max));
    ++summary_.images;
    return "<p class=\"def\">Error colour scale: 0 " + html::Img("images/heatmap_legend.png", "error colour scale") +
           " " + html::Number(100 * max, 0) + "% of the peak (and above).</p>\n";
  }

  void EnvMapsSection(std::ostringstream& s) {
    Section(s, "envmaps", "Environment maps");
    const Json list = figures_.contains("envmaps") ? figures_["envmaps"] : Json::array();
    if (list.empty()) {
      s << "<p class=\"na\">No environment maps (the evaluate stage did not run).</p>\n";
      return;
    }
    const bool truth = std::any_of(list.begin(), list.end(), [](const Json& e) { return e.contains("truth_oct"); });
    s << "<p class=\"def\">Recovered maps (octahedral: zenith at the centre, nadir at the corners; lat-long: zenith at "
         "the top)"
      << (truth ? ", rotated into the ground truth's frame and scaled per channel, beside the true maps at the same "
                  "exposure."
                : ", in the model's frame.")
      << "</p>\n";
    // What the photos determine of each map (inverse/lighting.json, inverse.map_resolution).
    std::map<std::string, Json> determined;
    const std::string lighting = Input("inverse").empty() ? "" : JoinPath(Input("inverse"), "lighting.json");
    if (IsFile(lighting)) {
      for (const Json& p : ReadJsonFile(lighting).value("photos", Json::array()))
        if (p.contains("determined_coefficients")) determined[p.value("name", "")] = p;
    }
    if (!determined.empty()) {
      s << "<p class=\"def\">Determined by the photos: how many of the map's coefficients the photos fix (the "
           "trace of the lighting step's resolution matrix; the rest of the map is the priors' fill-in), and the "
           "finest detail down to which at least half of every wavelet level is fixed. A diffuse object fixes few "
           "and coarse ones, a shiny one many and fine ones; detail finer than that in the map is not measured. "
           "The grey map beside it (same layout as the octahedral map) shows each direction's share from the "
           "photos: white where observations receive light from it, black where only the priors set it. Below "
           "it, the sun of a daylight model (sky, sun, ground) fitted to the seen part, and how much of the seen "
           "part's variation that model explains: low for light that is not open sky (walls, a courtyard, an "
           "interior), or for a map whose seen part is noise; its sun then means little. Last, which prior "
           "filled the unseen directions: the daylight model where it explains most of that variation (from "
           "70%), the smoothness prior where it explains little (to 30%), a blend of the two between.</p>\n";
    }
    std::vector<std::vector<std::string>> rows;
    const int oct_w = std::max(96, o_.tile_px / 2);
    for (size_t i : Spread(list.size(), o_.max_photos)) {
      const Json& e = list[i];
      const std::string name = e.value("name", "");
      std::vector<std::string> row{html::Escape(name),
                                   EvalFig(e, "oct", name + ": recovered (octahedral)", oct_w, "pixelated"),
                                   EvalFig(e, "latlong", name + ": recovered (lat-long)", 2 * oct_w)};
      if (!determined.empty()) {
        const auto it = determined.find(name);
        if (it == determined.end()) {
          row.push_back("<span class=\"na\">n/a</span>");
        } else {
          int total = 0;
          for (const Json& c : it->second.value("coefficients_per_level", Json::array())) total += c.get<int>();
          const Json& detail = it->second["resolved_detail_deg"];
          std::string cell = html::Number(Num(it->second, "determined_coefficients"), 0) + " of " +
                             std::to_string(total) +
                             (detail.is_number() ? ", detail to " + html::Number(detail.get<double>(), 0) + "&deg;"
                                                 : ", the mean only");
          if (it->second.contains("determined_map")) {
            const std::string rel = it->second["determined_map"].get<std::string>();
            cell = Fig(JoinPath(Input("inverse"), rel), "inverse/" + rel.substr(rel.find('/') + 1),
                       name + ": seen by the photos (white) or filled by the priors (black)", oct_w, "pixelated") +
                   "<br>" + cell;
          }
          if (it->second.contains("sun")) {  // the fitted daylight model's sun (solver/natural_light.h)
            const Json& sun = it->second["sun"];
            const std::vector<double> d = sun.value("direction_world", std::vector<double>{0, 0, 1});
            const double azimuth = std::atan2(d[1], d[0]) * 180.0 / M_PI;
            cell += "<br>sun " + html::Number(Num(sun, "elevation_deg"), 0) + "&deg; high, azimuth " +
                    html::Number(azimuth < 0 ? azimuth + 360 : azimuth, 0) + "&deg; from +X, " +
                    html::Number(100 * Num(sun, "irradiance_share"), 0) + "% of the light on the ground";
            // How far the seen part is daylight at all (low: walls, a courtyard, or a map the model cannot
            // make sense of, in which case its sun means little).
            if (sun.contains("daylight_explained_variation") && sun["daylight_explained_variation"].is_number())
              cell += "; the daylight model explains " +
                      html::Number(100 * Num(sun, "daylight_explained_variation"), 0) + "% of the seen part";
          }
          if (it->second.contains("daylight_fill") && it->second["daylight_fill"].is_number()) {
            const double fill = it->second["daylight_fill"].get<double>();
            cell += "<br>unseen directions filled by the ";
            if (fill >= 0.995)
              cell += "daylight model";
            else if (fill <= 0.005)
              cell += "smoothness prior";
            else
              cell += "daylight model (" + html::Number(100 * fill, 0) + "%) and the smoothness prior";
          }
          row.push_back(cell);
        }
      }
      if (truth) {
        row.push_back(EvalFig(e, "truth_oct", name + ": true (octahedral)", oct_w, "pixelated"));
        row.push_back(EvalFig(e, "truth_latlong", name + ": true (lat-long)", 2 * oct_w));
        row.push_back(html::Number(Num(e, "relative_error"), 3));
        row.push_back(html::Number(Num(e, "light_dir_error_deg"), 1));
      }
      rows.push_back(row);
    }
    std::vector<std::string> header{"photo", "recovered (oct)", "recovered (lat-long)"};
    if (!determined.empty()) header.push_back("determined by the photos");
    if (truth) {
      for (const char* h : {"true (oct)", "true (lat-long)", "relative error", "direction error [deg]"})
        header.push_back(h);
    }
    s << html::Table(header, rows, "images");
  }

  void MaterialsSection(std::ostringstream& s) {
    Section(s, "materials", "Albedo and materials");
    const auto albedo = Renders("albedo"), material = Renders("material");
    const Json eval_albedo = figures_.contains("albedo") ? figures_["albedo"] : Json::array();
    if (albedo.empty() && material.empty()) {
      s << "<p class=\"na\">No albedo or material images (relight.views is 0 or the relight stage did not run).</p>\n";
    }
    std::vector<std::vector<std::string>> rows;
    for (size_t k = 0; k < std::max(albedo.size(), material.size()); ++k) {
      std::vector<std::string> row;
      const std::string view = k < albedo.size() ? albedo[k]->view : material[k]->view;
      row.push_back(html::Escape(view));
      const Json* ev = nullptr;
      for (const auto& e : eval_albedo)
        if (e.value("view", "") == view) ev = &e;
      if (ev != nullptr) {
        row.push_back(EvalFig(*ev, "recovered", view + ": recovered albedo (scaled to the truth)"));
        row.push_back(EvalFig(*ev, "truth", view + ": true albedo"));
      } else {
        row.push_back(k < albedo.size() ? RelightFig(*albedo[k], view + ": recovered albedo") : "");
      }
      row.push_back(k < material.size() ? RelightFig(*material[k], view + ": dominant material") : "");
      rows.push_back(row);
    }
    if (!rows.empty()) {
      std::vector<std::string> header{"view", "recovered albedo"};
      if (!eval_albedo.empty()) header.push_back("true albedo");
      header.push_back("dominant material");
      s << html::Table(header, rows, "images");
    }
    const std::string materials = JoinPath(Input("inverse"), "materials.json");
    if (!Input("inverse").empty() && IsFile(materials)) {
      const ReflectanceModel model = ReadReflectanceModel(materials);
      std::vector<std::string> header{"material", "colour in the map", "diffuse albedo"};
      for (const auto& lobe : model.basis) header.push_back(html::Escape(lobe.Describe()));
      std::vector<std::vector<std::string>> mrows;
      for (size_t m = 0; m < model.materials.size(); ++m) {
        std::vector<std::string> row{std::to_string(m), Swatch(MaterialColor(int(m)).cast<double>())};
        Eigen::Vector3d diffuse = Eigen::Vector3d::Zero();
        for (size_t b = 0; b < model.basis.size(); ++b)
          if (model.basis[b].model == BrdfModel::kLambertian) diffuse += model.materials[m].coefficients[b];
        const double peak = std::max(1.0, diffuse.maxCoeff());
        row.push_back(Swatch(diffuse / peak) + html::Number(diffuse.x(), 3) + ", " + html::Number(diffuse.y(), 3) +
                      ", " + html::Number(diffuse.z(), 3));
        for (size_t b = 0; b < model.basis.size(); ++b) {
          const Eigen::Vector3d& c = model.materials[m].coefficients[b];
          row.push_back(html::Number(c.x(), 3) + ", " + html::Number(c.y(), 3) + ", " + html::Number(c.z(), 3));
        }
        mrows.push_back(row);
      }
      s << "<p class=\"def\">Recovered materials: RGB coefficient of each basis BRDF (inverse/materials.json; the "
           "scale "
           "is fixed by the inverse stage's gauge).</p>"
        << html::Table(header, mrows);
    }
    if (metrics_.contains("albedo")) {
      const Json& a = metrics_["albedo"];
      s << "<p class=\"def\">Albedo PSNR over the object's " << a.value("vertices", 0) << " observed vertices ("
        << html::Escape(a.value("correspondence", "")) << ")";
      if (a.contains("confident_psnr_db") && a["confident_psnr_db"].is_number())
        s << "; over the " << a.value("confident_vertices", 0)
          << " that two or more photos see with confidence: " << html::Number(a["confident_psnr_db"].get<double>(), 2)
          << " dB";
      if (a.contains("surroundings_psnr_db") && a["surroundings_psnr_db"].is_number())
        s << "; the surroundings (" << a.value("surroundings_vertices", 0)
          << " vertices on the true ground and occluders): " << html::Number(a["surroundings_psnr_db"].get<double>(), 2)
          << " dB";
      if (a.value("off_surface_vertices", 0) > 0)
        s << "; " << a.value("off_surface_vertices", 0) << " vertices lie on no true surface and are left out";
      s << ".</p>\n";
    }
  }

  void HeldOutSection(std::ostringstream& s) {
    Section(s, "heldout", "Held-out views relit");
    const Json list = figures_.contains("heldout") ? figures_["heldout"] : Json::array();
    if (list.empty()) {
      const auto hr = Renders("heldout");
      if (hr.empty()) {
        s << "<p class=\"na\">No held-out views (the ground truth has none).</p>\n";
        return;
      }
      for (const auto* r : hr) s << RelightFig(*r, r->name);
      return;
    }
    s << "<p class=\"def\">Views no photo was taken from, under environment maps no photo was taken under: the "
         "ground-truth render, the recovered model relit (scaled per channel), and the error.</p>\n";
    std::vector<std::vector<std::string>> rows;
    for (const auto& e : list) {
      const std::string name = e.value("name", "");
      rows.push_back({html::Escape(name), EvalFig(e, "reference", name + ": ground truth"),
                      EvalFig(e, "relit", name + ": relit model"), EvalFig(e, "error", name + ": error"),
                      html::Number(Num(e, "psnr_db"), 2),
                      e.contains("shadow_ratio_reference") ? html::Number(Num(e, "shadow_ratio_reference"), 1) + " / " +
                                                                 html::Number(Num(e, "shadow_ratio_relit"), 1)
                                                           : std::string("<span class=\"na\">&ndash;</span>")});
    }
    s << html::Table({"view and map", "ground truth", "relit", "error", "PSNR [dB]",
                      "sunlit &divide; shadow luminance (truth / relit)"},
                     rows, "images");
  }

  void NewLightSection(std::ostringstream& s) {
    Section(s, "relit", "Relit under new light");
    const auto novel = Renders("novel");
    if (novel.empty()) {
      s << "<p class=\"na\">No new-light renders (relight.views is 0 or the relight stage did not run).</p>\n";
      return;
    }
    std::vector<std::string> views, lights;
    for (const auto* r : novel) {
      if (std::find(views.begin(), views.end(), r->view) == views.end()) views.push_back(r->view);
      if (std::find(lights.begin(), lights.end(), r->light) == lights.end()) lights.push_back(r->light);
    }
    std::vector<std::vector<std::string>> rows;
    for (const auto& v : views) {
      std::vector<std::string> row{html::Escape(v)};
      for (const auto& l : lights) {
        std::string cell;
        for (const auto* r : novel)
          if (r->view == v && r->light == l) cell = RelightFig(*r, v + ", " + l);
        row.push_back(cell);
      }
      rows.push_back(row);
    }
    std::vector<std::string> header{"view"};
    for (const auto& l : lights) header.push_back(html::Escape(l));
    s << "<p class=\"def\">The recovered model from new orbit cameras under HDR environment maps, a directional and a "
         "point light (each with a dim uniform sky); exposure per image from the 99th luminance percentile of the "
         "object, sRGB.</p>"
      << html::Table(header, rows, "images");
  }

  void TurntableSection(std::ostringstream& s) {
    Section(s, "turntable", "Turntable");
    if (!turntable_gif_.empty()) {
      s << Fig(JoinPath(Input("relight"), turntable_gif_), "relight/turntable.gif", "turntable");
      return;
    }
    const auto frames = Renders("turntable");
    if (frames.empty()) {
      s << "<p class=\"na\">No turntable (relight.turntable_frames is 0).</p>\n";
      return;
    }
    for (size_t i : Spread(frames.size(), 8)) s << RelightFig(*frames[i], frames[i]->name, o_.tile_px / 2);
  }

  // Links the relight stage's export (model.glb, scene.json), copied with its maps into export/ beside the page.
  void ExportSection(std::ostringstream& s) {
    Section(s, "export", "Export for Blender");
    const std::string relight_dir = Input("relight");
    if (exported_.model.empty() || !IsFile(JoinPath(relight_dir, exported_.model))) {
      s << "<p class=\"na\">No export (the relight stage did not run, or an older version of it).</p>\n";
      return;
    }
    std::vector<std::string> files = {exported_.model, exported_.scene};
    files.insert(files.end(), exported_.envmaps.begin(), exported_.envmaps.end());
    for (const std::string& f : files) {
      if (!IsFile(JoinPath(relight_dir, f))) {
        summary_.notes.push_back("missing export file " + JoinPath(relight_dir, f));
        continue;
      }
      EnsureDir(fs::path(JoinPath(out_, f)).parent_path().string());
      WriteFileAtomic(JoinPath(out_, f), ReadFileToString(JoinPath(relight_dir, f)));
    }
    s << "<p class=\"def\">The recovered model for Blender and other glTF 2.0 tools: <a href=\""
      << html::Escape(exported_.model) << "\">model.glb</a> (" << exported_.vertices << " vertices, "
      << exported_.triangles
      << " triangles; one primitive and material per dominant material, the diffuse albedo as vertex colour, "
         "+Y up) and <a href=\""
      << html::Escape(exported_.scene) << "\">scene.json</a> (which of the " << exported_.envmaps.size()
      << " environment maps in export/envmaps/ and which camera belong to which photo). Conventions and the "
         "import into Blender: docs/FORMATS.md, \"Export\".</p>\n";
    // The interactive viewer (relight/viewer_export.h), copied beside the page when the relight stage wrote it.
    const std::string viewer = "export/viewer/viewer.html", viewer_data = "export/viewer/viewer_data.js";
    if (IsFile(JoinPath(relight_dir, viewer)) && IsFile(JoinPath(relight_dir, viewer_data))) {
      EnsureDir(JoinPath(out_, "export/viewer"));
      for (const std::string& f : {viewer, viewer_data})
        WriteFileAtomic(JoinPath(out_, f), ReadFileToString(JoinPath(relight_dir, f)));
      s << "<p class=\"def\"><a href=\"" << viewer
        << "\">Interactive viewer</a>: the model relit in the browser (WebGL) under each map, with sliders "
           "for the light's turn about +Z, the camera and the exposure (docs/FORMATS.md, \"Viewer\").</p>\n";
    }
  }

  void ConvergenceSection(std::ostringstream& s) {
    Section(s, "convergence", "Convergence of the inverse solve");
    const std::string path = JoinPath(Input("inverse"), "solve_summary.json");
    if (Input("inverse").empty() || !IsFile(path)) {
      s << "<p class=\"na\">No solve summary (the inverse stage did not run).</p>\n";
      return;
    }
    const Json j = ReadJsonFile(path);
    std::vector<std::vector<std::string>> csv, rows;
    double elapsed = j.value("transport_seconds", 0.0);
    for (const auto& it : j.value("iterations", Json::array())) {
      elapsed += Num(it, "lighting_seconds", 0) + Num(it, "reflectance_seconds", 0);
      const double holdout = Num(it, "holdout_rmse");
      csv.push_back({std::to_string(it.value("iteration", 0)), CsvNumber(Num(it, "train_rmse")),
                     CsvNumber(holdout > 0 ? holdout : NAN), CsvNumber(Num(it, "objective")), CsvNumber(elapsed)});
      rows.push_back({std::to_string(it.value("iteration", 0)), html::Number(Num(it, "train_rmse"), 6),
                      html::Number(holdout, 6), html::Number(Num(it, "lighting_seconds"), 2),
                      html::Number(Num(it, "reflectance_seconds"), 2)});
    }
    s << "<p class=\"def\">Confidence-weighted RMSE of the training and held-out observations (linear photo units) "
         "after every outer iteration; the iterate with the lowest held-out error is kept (best: iteration "
      << j.value("best_iteration", 0) << "; stopped: " << html::Escape(j.value("stop_reason", "")) << ").</p>\n";
    if (!csv.empty()) {
      s << Chart("convergence", {"iteration", "train_rmse", "holdout_rmse", "objective", "elapsed_s"}, csv,
                 "set xlabel 'iteration'\nset ylabel 'RMSE (linear photo units)'\nset logscale y\nset key top right\n"
                 "plot 'convergence.csv' skip 1 using 1:2 with linespoints lw 2 title 'training', \\\n"
                 "     '' skip 1 using 1:3 with linespoints lw 2 title 'held-out'");
      s << html::Table({"iteration", "training RMSE", "held-out RMSE", "lighting [s]", "reflectance [s]"}, rows);
    }
    AccuracyTimeChart(s, j);
  }

  // Held-out error against the solve's wall clock for everything the solve tried: every iteration of every
  // start (inverse.init_gloss), every model-selection candidate, and the kept iterate marked.
  void AccuracyTimeChart(std::ostringstream& s, const Json& j) {
    const Json starts = j.value("starts", Json::array());
    bool timed = false;
    for (const auto& st : starts) timed |= st.contains("solve_seconds") && !st["solve_seconds"].empty();
    if (!timed) return;
    bool holdout = false;
    for (const auto& st : starts)
      for (const auto& v : st.value("holdout_rmse", std::vector<double>{})) holdout |= v > 0;
    const char* error_key = holdout ? "holdout_rmse" : "train_rmse";
    // Rows: series (0..S-1 the starts, S the candidates, S+1 the kept iterate), label, seconds, error.
    std::vector<std::vector<std::string>> csv, table;
    const int num_starts = static_cast<int>(starts.size());
    double kept_seconds = NAN, kept_error = NAN;
    for (int k = 0; k < num_starts; ++k) {
      const Json& st = starts[k];
      const auto t = st.value("solve_seconds", std::vector<double>{});
      const auto e = st.value(error_key, std::vector<double>{});
      for (size_t i = 0; i < t.size() && i < e.size(); ++i)
        csv.push_back({std::to_string(k),
                       CsvField("start " + std::to_string(k + 1) + " iteration " + std::to_string(i + 1)),
                       CsvNumber(t[i]), CsvNumber(e[i])});
      const int best = st.value("best_iteration", 0);
      if (st.value("chosen", false) && best >= 1 && size_t(best) <= std::min(t.size(), e.size())) {
        kept_seconds = t[best - 1];
        kept_error = e[best - 1];
      }
      table.push_back({"start " + std::to_string(k + 1) + " (init_gloss " + html::Number(Num(st, "init_gloss"), 2) +
                           ")" + (st.value("chosen", false) ? " <b>kept</b>" : ""),
                       std::to_string(st.value("iterations", 0)), html::Number(Num(st, "score"), 6),
                       html::Number(Num(st, "seconds"), 1)});
    }
    bool candidates = false;
    if (j.contains("model_selection"))
      for (const auto& c : j["model_selection"].value("candidates", Json::array())) {
        candidates = true;
        const double e = Num(c, error_key);
        csv.push_back({std::to_string(num_starts), CsvField(c.value("model", "")), CsvNumber(Num(c, "solve_seconds")),
                       CsvNumber(e)});
        table.push_back(
            {"candidate: " + html::Escape(c.value("model", "")) + (c.value("chosen", false) ? " <b>chosen</b>" : ""),
             "", html::Number(e, 6), html::Number(Num(c, "seconds"), 1)});
      }
    if (std::isfinite(kept_seconds))
      csv.push_back({std::to_string(num_starts + 1), "kept", CsvNumber(kept_seconds), CsvNumber(kept_error)});
    std::ostringstream body;
    body << "set xlabel 'seconds since the solve began (transport rows included)'\n"
         << "set ylabel '" << (holdout ? "held-out" : "training") << " RMSE (linear photo units)'\n"
         << "set key top right\nplot ";
    for (int k = 0; k < num_starts; ++k)
      body << (k ? ", \\\n     " : "") << "'accuracy_time.csv' skip 1 using 3:($1==" << k
           << " ? $4 : NaN) with linespoints lw 2 title 'start " << k + 1 << " (init_gloss "
           << html::Number(Num(starts[k], "init_gloss"), 2) << ")'";
    if (candidates)
      body << ", \\\n     'accuracy_time.csv' skip 1 using 3:($1==" << num_starts
           << " ? $4 : NaN) with points pt 6 ps 1.2 title 'model candidates'";
    body << ", \\\n     'accuracy_time.csv' skip 1 using 3:($1==" << num_starts + 1
         << " ? $4 : NaN) with points pt 7 ps 2.2 lc rgb '#cc0000' title 'kept'";
    s << "<h3>Accuracy against time</h3><p class=\"def\">" << (holdout ? "Held-out" : "Training")
      << " RMSE of every iterate the solve computed, against the wall clock since the solve began: each start's "
         "iterations (a start that lost the race stops early), each model-selection candidate's best iterate "
         "(inverse.select_model), and the iterate kept (red).</p>\n"
      << Chart("accuracy_time", {"series", "label", "solve_seconds", error_key}, csv, body.str())
      << html::Table({"tried", "iterations", std::string(holdout ? "held-out" : "training") + " RMSE", "seconds"},
                     table);
  }

  void LeaveOneOutSection(std::ostringstream& s) {
    Section(s, "loo", "Leave-one-photo-out");
    const Json loo = metrics_.contains("leave_one_out") ? metrics_["leave_one_out"] : Json();
    const Json photos = loo.is_object() && loo.contains("photos") ? loo["photos"] : Json::array();
    if (photos.empty()) {
      std::string reason = "the evaluate stage did not run";
      if (metrics_.contains("not_available") && metrics_["not_available"].contains("loo_psnr_db"))
        reason = metrics_["not_available"]["loo_psnr_db"].get<std::string>();
      s << "<p class=\"na\">Not computed: " << html::Escape(reason) << ".</p>\n";
    } else {
      s << "<p class=\"def\">For each scored photo, the reflectance is solved from the other photos only (a short "
           "solve "
           "started from a reflectance solved without the photo's group, docs/METRICS.md), then just this photo's "
           "environment map is fitted; the render is scored like the re-renderings (which did see the photo), and "
           "the headline compares the two over the same photos.</p>\n";
      std::map<std::string, double> rerender;
      if (metrics_.contains("rerender"))
        for (const auto& p : metrics_["rerender"].value("photos", Json::array()))
          rerender[p.value("name", "")] = Num(p, "psnr_db");
      std::map<std::string, const Json*> figs;
      if (figures_.contains("loo"))
        for (const auto& f : figures_["loo"]) figs[f.value("name", "")] = &f;
      std::vector<std::vector<std::string>> rows;
      for (const auto& p : photos) {
        const std::string name = p.value("name", "");
        auto f = figs.find(name);
        rows.push_back({html::Escape(name), html::Number(Num(p, "psnr_db"), 2),
                        html::Number(rerender.count(name) ? rerender[name] : NAN, 2),
                        html::Number(Num(p, "seconds"), 1),
                        f != figs.end() ? EvalFig(*f->second, "render", name + ": leave-one-out render") : "",
                        f != figs.end() ? EvalFig(*f->second, "error", name + ": leave-one-out error") : ""});
      }
      s << html::Table({"photo", "leave-one-out PSNR [dB]", "re-render PSNR [dB]", "seconds", "render", "error"}, rows,
                       "images");
    }
    // Per-photo chart: re-rendering PSNR (and leave-one-out where computed).
    if (metrics_.contains("rerender")) {
      std::map<std::string, double> loo_psnr;
      for (const auto& p : photos) loo_psnr[p.value("name", "")] = Num(p, "psnr_db");
      std::vector<std::vector<std::string>> csv;
      for (const auto& p : metrics_["rerender"].value("photos", Json::array())) {
        const std::string name = p.value("name", "");
        csv.push_back({name, CsvNumber(Num(p, "psnr_db")), CsvNumber(loo_psnr.count(name) ? loo_psnr[name] : NAN)});
      }
      if (!csv.empty()) {
        s << "<h3>Per-photo scores</h3>"
          << Chart("photo_psnr", {"photo", "rerender_psnr_db", "loo_psnr_db"}, csv,
                   std::string("set ylabel 'PSNR [dB]'\nset style data histogram\nset style histogram clustered gap 1\n"
                               "set style fill solid 0.8 border -1\nset yrange [0:*]\nset key top right\n") +
                       (csv.size() > 24 ? "set xtics format ''\n" : "set xtics rotate by -45 font ',8'\n") +
                       "plot 'photo_psnr.csv' skip 1 using 2:xtic(1) title 're-rendering', '' skip 1 using 3 title "
                       "'leave-one-out'",
                   800, 360);
      }
    }
  }

  void TimingsSection(std::ostringstream& s) {
    Section(s, "timings", "Stage timings");
    OrderedJson seconds = CollectStageSeconds(inputs_);
    if (seconds.empty() && metrics_.contains("seconds")) seconds = metrics_["seconds"];
    if (seconds.empty()) {
      s << "<p class=\"na\">No timings (the stages were not run by the pipeline).</p>\n";
      return;
    }
    std::vector<std::vector<std::string>> rows, csv;
    double total = 0;
    for (const auto& [stage, v] : seconds.items()) {
      if (stage == "total") continue;
      const double x = v.get<double>();
      total += x;
      rows.push_back({html::Escape(stage), html::Number(x, 1), html::Escape(Progress::FormatSeconds(x))});
      csv.push_back({stage, CsvNumber(x)});
    }
    rows.push_back({"<b>total</b>", html::Number(total, 1), html::Escape(Progress::FormatSeconds(total))});
    s << "<p class=\"def\">Wall-clock seconds of each stage's run (from its status.json; a cached stage shows the time "
         "of the run that made it). The report stage itself is not included.</p>"
      << html::Table({"stage", "seconds", ""}, rows)
      << Chart("timings", {"stage", "seconds"}, csv,
               "set ylabel 'seconds'\nset style fill solid 0.8 border -1\nset boxwidth 0.7\nset yrange [0:*]\n"
               "set xtics rotate by -30\nplot 'timings.csv' skip 1 using 0:2:xtic(1) with boxes lc rgb '#4477aa' "
               "notitle");
  }

  const ReportOptions& o_;
  const std::map<std::string, std::string>& inputs_;
  const std::string out_;
  Json metrics_;
  Json figures_ = Json::object();
  std::vector<RenderRecord> renders_;
  std::string turntable_gif_;
  ExportRecord exported_;
  std::vector<std::pair<std::string, std::string>> nav_;
  ReportSummary summary_;
};

}  // namespace

std::map<std::string, std::string> ReportInputs::ByStage() const {
  std::map<std::string, std::string> by_stage;
  const std::pair<const char*, const std::string*> all[] = {
      {"ingest", &ingest_dir},   {"sfm", &sfm_dir},         {"mesh", &mesh_dir},       {"linearize", &linearize_dir},
      {"observe", &observe_dir}, {"inverse", &inverse_dir}, {"relight", &relight_dir}, {"evaluate", &evaluate_dir}};
  for (const auto& [stage, dir] : all) {
    if (!dir->empty()) by_stage[stage] = *dir;
  }
  return by_stage;
}

std::string ReportSummary::BriefReport() const {
  std::string s = fmt::format("report: {} images, {} charts, {}", images, charts, page);
  for (const auto& note : notes) s += "; note: " + note;
  return s + "; " + Progress::FormatSeconds(seconds);
}

ReportSummary RunReport(const ReportOptions& options, const ReportInputs& inputs, const std::string& output_dir) {
  options.Check();
  const std::map<std::string, std::string> by_stage = inputs.ByStage();
  ReportBuilder builder(options, by_stage, output_dir);
  builder.Build();
  ReportSummary summary = builder.summary();
  summary.page = JoinPath(output_dir, "index.html");
  return summary;
}

}  // namespace relight
