#include "evaluate/evaluate.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include "core/config.h"
#include "core/error.h"
#include "core/fs.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/stats.h"
#include "core/timer.h"
#include "datasets/diligent.h"
#include "datasets/ground_truth.h"
#include "datasets/ground_truth_frame.h"
#include "datasets/light_evaluation.h"
#include "evaluate/envmap_metrics.h"
#include "evaluate/image_metrics.h"
#include "evaluate/leave_one_out.h"
#include "evaluate/shadow_contrast.h"
#include "evaluate/surface_distance.h"
#include "geometry/mesh_io.h"
#include "geometry/raycaster.h"
#include "observe/observations.h"
#include "relight/display.h"
#include "relight/relight.h"
#include "relight/transport_render.h"
#include "render/render_view.h"
#include "render/rng.h"
#include "solver/inverse.h"
#include "sphere/envmap.h"

namespace relight {
namespace fs = std::filesystem;

namespace {

std::string Stem(const std::string& name) { return fs::path(name).stem().string(); }
bool IsFile(const std::string& path) { return !path.empty() && fs::is_regular_file(path); }
OrderedJson Vec(const Eigen::Vector3d& v) { return OrderedJson::array({v.x(), v.y(), v.z()}); }

// Shadow contrast is measured only where the view shows at least this many sunlit and shadowed pixels
// (after the regions' erosion): a ratio over a few dozen pixels is noise.
constexpr size_t kMinShadowRegionPixels = 100;

// Reads a stage's resolved options from <dir>/config.yaml (written by the orchestrator); false when absent.
template <typename Options>
bool ReadResolvedOptions(const std::string& stage_dir, const std::string& section, Options* options) {
  const std::string path = JoinPath(stage_dir, "config.yaml");
  if (stage_dir.empty() || !IsFile(path)) return false;
  OptionTable table = MakeOptionTable(section, options);
  ConfigDocument::Load(path).Apply(&table);
  return true;
}

// Which vertices photo `photo` observes (1 = observed), one entry per vertex.
// Lower bounds (clipped footprints) do not count: their pixels are not a measurement.
std::vector<char> ObservedVertices(const ObservationSet& obs, uint32_t photo) {
  std::vector<char> observed(obs.num_vertices, 0);
  for (const auto& o : obs.records)
    if (o.photo == photo && !o.lower_bound()) observed[o.vertex] = 1;
  return observed;
}

// 1 where the pixel-centre ray first hits the object (geometry 0) on a face whose three vertices the photo
// observes.
Image ObservedPixelMask(const RayCaster& caster, const std::vector<char>& observed, const Camera& camera,
                        const ImageRecord& pose) {
  const TriangleMesh& mesh = caster.mesh(0);
  const std::vector<RayHit> hits = CastPixelCentres(caster, camera, pose);
  Image mask(camera.width, camera.height, 1);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      const RayHit& h = hits[size_t(y) * camera.width + x];
      if (!h.hit || h.geom_id != 0) continue;
      const Eigen::Vector3i& f = mesh.faces[h.prim_id];
      if (observed[f[0]] && observed[f[1]] && observed[f[2]]) mask.at(x, y) = 1;
    }
  return mask;
}

// The linear photo (and its confidence) at the render's size.
struct PhotoReference {
  Image linear;
  Image confidence;  // empty when linearize wrote none
};
PhotoReference LoadPhotoReference(const std::string& linearize_dir, const std::string& stem, int width, int height) {
  PhotoReference ref;
  const std::string linear = JoinPath(linearize_dir, "linear/" + stem + ".exr");
  if (!IsFile(linear)) {
    RELIGHT_USER_ERROR() << "'" << linear << "' is missing: the linearize stage has no linear image of photo '" << stem
                         << "'; rerun from linearize";
  }
  ref.linear = ReadImage(linear);
  const std::string conf = JoinPath(linearize_dir, "confidence/" + stem + ".exr");
  if (IsFile(conf)) ref.confidence = ReadImage(conf);
  if (ref.linear.width != width || ref.linear.height != height) {
    const double sx = double(width) / ref.linear.width, sy = double(height) / ref.linear.height;
    if (std::abs(sx - sy) > 0.02 * sx) {
      RELIGHT_USER_ERROR() << "'" << linear << "' is " << ref.linear.width << "x" << ref.linear.height
                           << " but the re-rendering is " << width << "x" << height
                           << " (another aspect ratio); rerun from the relight stage";
    }
    ref.linear = ResizeImage(ref.linear, width, height);
    if (!ref.confidence.empty()) ref.confidence = ResizeImage(ref.confidence, width, height);
  }
  return ref;
}

// Observed-pixel mask combined with the photo's confidence, eroded.
Image ComparisonMask(const Image& observed_mask, const PhotoReference& ref, const EvaluateOptions& o) {
  Image mask = observed_mask;
  if (!ref.confidence.empty()) {
    for (int y = 0; y < mask.height; ++y)
      for (int x = 0; x < mask.width; ++x)
        if (ref.confidence.at(x, y) < o.min_confidence) mask.at(x, y) = 0;
  }
  return ErodeMask(mask, o.mask_erosion_px);
}

ImageCompareOptions CompareOptions(const EvaluateOptions& o) {
  ImageCompareOptions c;
  c.peak_percentile = o.peak_percentile;
  c.clip_to_peak = o.clip_to_peak;
  return c;
}

OrderedJson ComparisonJson(const ImageComparison& c) {
  OrderedJson j;
  j["psnr_db"] = c.psnr_db;
  j["rmse"] = c.rmse;
  j["relative_rmse"] = c.relative_rmse;
  j["peak"] = c.peak;
  j["scale"] = Vec(c.scale);
  j["pixels"] = c.pixels;
  return j;
}

// Reference | scaled estimate | heat map, the first two at the reference's exposure.
void WriteComparisonFigures(const Image& ref, const Image& est, const Image& mask, const ImageComparison& c,
                            const EvaluateOptions& o, const std::string& ref_png, const std::string& est_png,
                            const std::string& error_png) {
  const double exposure = PercentileExposure(ref, &mask, 99);
  WritePng(ref_png, ToneMapSrgb(ref, exposure));
  WritePng(est_png, ToneMapSrgb(ScaleChannels(est, c.scale), exposure));
  WritePng(error_png, HeatMap(RelativeErrorImage(ref, est, c.scale, c.peak), o.heatmap_max, &mask));
}

// Records a metric that cannot be computed.
void NotAvailable(OrderedJson* m, const std::string& key, const std::string& reason) {
  (*m)[key] = nullptr;
  (*m)["not_available"][key] = reason;
}

// Recovered against true albedo after the best per-channel scale (the
// reflectance's scale is a gauge): PSNR with peak 1.
struct AlbedoScore {
  size_t vertices = 0;
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();
  double rmse = 0;
  double psnr_db = 0;
};

AlbedoScore ScoreAlbedo(const std::vector<Eigen::Vector3d>& truth, const std::vector<Eigen::Vector3d>& estimate) {
  AlbedoScore a;
  a.vertices = truth.size();
  if (truth.empty()) return a;
  Eigen::Vector3d te = Eigen::Vector3d::Zero(), ee = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < truth.size(); ++k) {
    te += truth[k].cwiseProduct(estimate[k]);
    ee += estimate[k].cwiseProduct(estimate[k]);
  }
  for (int c = 0; c < 3; ++c) a.scale[c] = ee[c] > 0 ? te[c] / ee[c] : 1.0;
  double se = 0;
  for (size_t k = 0; k < truth.size(); ++k) se += (a.scale.cwiseProduct(estimate[k]) - truth[k]).squaredNorm();
  const double mse = se / (3.0 * truth.size());
  a.rmse = std::sqrt(mse);
  a.psnr_db = mse > 0 ? std::min(kMaxPsnrDb, 10 * std::log10(1.0 / mse)) : kMaxPsnrDb;
  return a;
}

}  // namespace

const std::vector<std::string>& HeadlineMetricKeys() {
  static const std::vector<std::string> keys = {
      "relight_psnr_db",  "shadow_contrast_error", "rerender_psnr_db", "rerender_rmse",
      "envmap_rel_error", "light_dir_error_deg",   "albedo_psnr_db",   "loo_psnr_db"};
  return keys;
}

std::string EvaluateSummary::BriefReport() const {
  std::ostringstream s;
  s << "evaluate: ";
  bool first = true;
  for (const auto& key : HeadlineMetricKeys()) {
    if (!metrics.contains(key) || metrics[key].is_null()) continue;
    s << (first ? "" : ", ") << key << " " << metrics[key].get<double>();
    first = false;
  }
  if (first) s << "no metric could be computed";
  s << "; " << Progress::FormatSeconds(seconds);
  return s.str();
}

OrderedJson CollectStageSeconds(const std::map<std::string, std::string>& inputs) {
  std::map<std::string, double> seconds;
  std::vector<std::pair<std::string, std::string>> queue(inputs.begin(), inputs.end());
  std::set<std::string> seen;
  while (!queue.empty()) {
    const auto [stage, dir] = queue.back();
    queue.pop_back();
    if (!seen.insert(stage).second) continue;
    const std::string status = JoinPath(dir, "status.json");
    if (!IsFile(status)) continue;
    const Json j = ReadJsonFile(status);
    seconds[stage] = j.value("seconds", 0.0);
    if (j.contains("upstream") && j["upstream"].is_object()) {
      const fs::path cache = fs::path(dir).parent_path().parent_path();  // <workspace>/cache
      for (const auto& [up, key] : j["upstream"].items()) {
        const std::string up_dir = (cache / up / key.get<std::string>()).string();
        if (!seen.count(up) && fs::is_directory(up_dir)) queue.emplace_back(up, up_dir);
      }
    }
  }
  // Pipeline order for readability.
  static const std::vector<std::string> order = {"synthesize", "ingest",  "sfm",     "mvs",     "mesh",     "linearize",
                                                 "visibility", "observe", "inverse", "relight", "evaluate", "report"};
  OrderedJson out = OrderedJson::object();
  for (const auto& s : order)
    if (seconds.count(s)) out[s] = seconds[s];
  for (const auto& [s, v] : seconds)
    if (!out.contains(s)) out[s] = v;
  return out;
}

namespace {

// What the evaluate steps share: the options, the upstream folders, the ground truth and its frame, and the
// inputs several steps score against. Not copyable: `caster` points into `mesh` and `occluders`.
struct EvaluateContext {
  EvaluateContext(const EvaluateOptions& o, const EvaluateInputs& in, const std::string& dir)
      : options(o), inputs(in), output_dir(dir), compare(CompareOptions(o)) {}
  EvaluateContext(const EvaluateContext&) = delete;
  EvaluateContext& operator=(const EvaluateContext&) = delete;

  const EvaluateOptions& options;
  const EvaluateInputs& inputs;
  const std::string& output_dir;
  const ImageCompareOptions compare;
  GroundTruth truth = GroundTruth::At("");      // the folder ingest carried along; none without the ingest stage
  bool has_gt = false;                          // that folder exists
  GroundTruthFrame frame;                       // the model's frame related to the ground truth's
  std::vector<RenderRecord> renders;            // relight's index; empty when the stage did not run
  ObservationSet observations;                  // <observe>/observations.bin; empty when the stage did not run
  std::map<std::string, uint32_t> photo_index;  // photo name -> its index in `observations`
  TriangleMesh mesh, occluders;                 // <mesh>/mesh.ply and occluders.ply
  std::unique_ptr<RayCaster> caster;            // over `mesh` (geometry 0) and `occluders`; null without a mesh
};

// The headers of metrics.json (every headline metric null until a step computes it) and figures.json, and the
// figure folders.
void StartOutputs(const EvaluateOptions& o, const std::string& output_dir, OrderedJson* metrics, OrderedJson* figures) {
  OrderedJson& m = *metrics;
  OrderedJson& fig = *figures;
  m["format"] = "relight-metrics";
  m["version"] = 1;
  m["definitions"] = "docs/METRICS.md";
  for (const auto& key : HeadlineMetricKeys()) m[key] = nullptr;
  m["not_available"] = OrderedJson::object();
  fig["format"] = "relight-figures";
  fig["version"] = 1;
  fig["heatmap_max"] = o.heatmap_max;
  for (const char* sub : {"rerender", "heldout", "envmaps", "albedo", "loo"})
    EnsureDir(JoinPath(output_dir, std::string("figures/") + sub));
}

// The ground truth's folder and the model's frame related to it, recorded in "ground_truth" and "frame".
void RelateToTruth(EvaluateContext* ctx, OrderedJson* metrics) {
  OrderedJson& m = *metrics;
  const EvaluateInputs& in = ctx->inputs;
  ctx->truth = GroundTruth::OfIngest(in.ingest_dir);
  ctx->has_gt = ctx->truth.Exists();
  if (ctx->has_gt) ctx->frame = RelateToGroundTruth(in.sfm_dir, ctx->truth);
  const GroundTruthFrame& frame = ctx->frame;
  m["ground_truth"] = ctx->has_gt;
  m["frame"] = {{"method", frame.available ? frame.method : "none"}, {"reason", frame.reason}};
  if (frame.available && !frame.IsIdentity()) {
    const Sim3& t = frame.truth_from_model;
    m["frame"]["truth_from_model"] = {
        {"scale", t.scale},
        {"rotation",
         {t.rotation(0, 0), t.rotation(0, 1), t.rotation(0, 2), t.rotation(1, 0), t.rotation(1, 1), t.rotation(1, 2),
          t.rotation(2, 0), t.rotation(2, 1), t.rotation(2, 2)}},
        {"translation", Vec(t.translation)}};
  }
}

// The inputs several steps read: relight's render index, the observations and the mesh with its ray caster.
void LoadSharedInputs(EvaluateContext* ctx) {
  const EvaluateInputs& in = ctx->inputs;
  if (!in.relight_dir.empty()) ctx->renders = ReadRenderIndex(in.relight_dir);
  std::vector<ObservedPhoto> photos;
  if (!in.observe_dir.empty()) {
    ctx->observations = ReadObservations(JoinPath(in.observe_dir, "observations.bin"));
    photos = ReadObservedPhotos(JoinPath(in.observe_dir, "photos.json"));
  }
  for (const auto& p : photos) ctx->photo_index[p.name] = p.index;
  if (!in.mesh_dir.empty()) {
    ctx->mesh = ReadMesh(JoinPath(in.mesh_dir, "mesh.ply"));
    if (IsFile(JoinPath(in.mesh_dir, "occluders.ply")))
      ctx->occluders = ReadMesh(JoinPath(in.mesh_dir, "occluders.ply"));
  }
  if (!ctx->mesh.empty()) {
    std::vector<const TriangleMesh*> meshes{&ctx->mesh};
    if (!ctx->occluders.empty()) meshes.push_back(&ctx->occluders);
    ctx->caster = std::make_unique<RayCaster>(meshes);
  }
}

// The pixels re-rendering `r` of photo `photo` is scored on: observed and confident, and with the true object
// mask (synthetic scenes) only the object's (then `object_only` is set).
Image RerenderMask(const EvaluateContext& ctx, const RenderRecord& r, uint32_t photo, const PhotoReference& ref,
                   bool* object_only) {
  Image mask = ComparisonMask(
      ObservedPixelMask(*ctx.caster, ObservedVertices(ctx.observations, photo), r.camera.camera, r.camera.pose), ref,
      ctx.options);
  // With the true object mask (synthetic scenes), score the object, as the held-out views do:
  // a reconstructed mesh also holds the ground around it.
  const std::string object_mask_path = ctx.truth.MaskPath(fs::path(r.view).stem().string());
  *object_only = false;
  if (ctx.has_gt && IsFile(object_mask_path)) {
    const Image object_mask = ReadMask(object_mask_path);
    if (object_mask.width == mask.width && object_mask.height == mask.height) {
      for (size_t k = 0; k < mask.pixels.size(); ++k)
        if (object_mask.pixels[k] < 0.5f) mask.pixels[k] = 0;
      *object_only = true;
    }
  }
  return mask;
}

// The re-rendering metrics: relight's re-renderings of the input photos against the linear photos, into
// `metrics`, their figures into `figures`.
void ScoreRerenders(const EvaluateContext& ctx, OrderedJson* metrics, OrderedJson* figures) {
  const EvaluateOptions& o = ctx.options;
  const EvaluateInputs& in = ctx.inputs;
  OrderedJson& m = *metrics;
  OrderedJson& fig = *figures;
  OrderedJson list = OrderedJson::array();
  fig["rerender"] = OrderedJson::array();
  std::vector<double> psnr, rel;
  std::string reason;
  if (in.relight_dir.empty())
    reason = "the relight stage did not run";
  else if (in.linearize_dir.empty() || in.observe_dir.empty())
    reason = "the linearize or observe stage did not run";
  else if (!ctx.caster)
    reason = "the mesh stage did not run";
  if (reason.empty()) {
    int count = 0;
    for (const auto& r : ctx.renders) count += r.kind == "rerender";
    if (count == 0) reason = "the relight stage rendered no input photo (relight.rerender is off)";
    Progress progress("score re-renderings", std::max(1, count));
    for (const auto& r : ctx.renders) {
      if (r.kind != "rerender") continue;
      auto it = ctx.photo_index.find(r.view);
      if (it == ctx.photo_index.end() || ctx.mesh.num_vertices() != ctx.observations.num_vertices) {
        RELIGHT_USER_ERROR() << "photo '" << r.view << "' was re-rendered but '"
                             << JoinPath(in.observe_dir, "photos.json")
                             << "' does not list it (or the mesh and observations disagree); rerun from observe";
      }
      const Image est = ReadImage(JoinPath(in.relight_dir, r.exr));
      const PhotoReference ref = LoadPhotoReference(in.linearize_dir, r.name, est.width, est.height);
      bool object_only = false;
      const Image mask = RerenderMask(ctx, r, it->second, ref, &object_only);
      OrderedJson e;
      e["name"] = r.view;
      e["region"] = object_only ? "object (true mask)" : "observed surface";
      if (CountMask(mask) == 0) {
        e["psnr_db"] = nullptr;
        e["reason"] = "no observed, unclipped pixel";
        list.push_back(e);
        progress.Advance();
        continue;
      }
      const ImageComparison c = CompareScaleInvariant(ref.linear, est, mask, ctx.compare, r.view);
      e.update(ComparisonJson(c));
      list.push_back(e);
      psnr.push_back(c.psnr_db);
      rel.push_back(c.relative_rmse);
      const std::string base = "figures/rerender/" + r.name;
      WriteComparisonFigures(ref.linear, est, mask, c, o, JoinPath(ctx.output_dir, base + "_photo.png"),
                             JoinPath(ctx.output_dir, base + "_rerender.png"),
                             JoinPath(ctx.output_dir, base + "_error.png"));
      fig["rerender"].push_back({{"name", r.view},
                                 {"photo", base + "_photo.png"},
                                 {"rerender", base + "_rerender.png"},
                                 {"error", base + "_error.png"},
                                 {"psnr_db", c.psnr_db}});
      progress.Advance();
    }
    if (psnr.empty() && reason.empty()) reason = "no re-rendered photo has an observed, unclipped pixel";
  }
  m["rerender"] = {{"photos", list}, {"scored", psnr.size()}};
  if (psnr.empty()) {
    NotAvailable(&m, "rerender_psnr_db", reason);
    NotAvailable(&m, "rerender_rmse", reason);
  } else {
    m["rerender_psnr_db"] = Mean(psnr);
    m["rerender_rmse"] = Mean(rel);
    m["rerender"]["median_psnr_db"] = Median(psnr);
    m["rerender"]["min_psnr_db"] = *std::min_element(psnr.begin(), psnr.end());
  }
}

// What the ground truth holds for scoring the held-out renders beyond their images: the suns of the held-out
// skies, and the true geometry and held-out cameras the sunlit and shadowed regions are traced in (null
// `caster`: none). Not copyable: `caster` points into the meshes.
struct HeldoutTruth {
  HeldoutTruth() = default;
  HeldoutTruth(const HeldoutTruth&) = delete;
  HeldoutTruth& operator=(const HeldoutTruth&) = delete;

  std::string dir;                                       // <ground truth>/relight
  std::map<std::string, Eigen::Vector3d> sun_by_envmap;  // sun_dir_world of each held-out sky that has one
  TriangleMesh object, occluders;
  std::unique_ptr<RayCaster> caster;
  Reconstruction views;  // the held-out cameras
};

// Reads the suns of the held-out maps of `heldout` (the ground truth's relight/index.json) and, when there is
// one, the true geometry and held-out cameras into `truth`.
void LoadHeldoutTruth(const GroundTruth& gt, const TrueHeldout& heldout, HeldoutTruth* truth) {
  truth->dir = heldout.dir;
  // Shadow contrast under the held-out skies' suns, over regions from the true geometry.
  for (const auto& e : heldout.envmaps) {
    const Json& d = e.details;
    if (d.value("source", "") == "sky" && d.contains("sun_dir_world")) {
      const auto v = d.at("sun_dir_world").get<std::vector<double>>();
      truth->sun_by_envmap[e.name] = Eigen::Vector3d(v[0], v[1], v[2]);
    }
  }
  if (!truth->sun_by_envmap.empty() && gt.HasMesh()) {
    truth->object = ReadMesh(gt.MeshPath());
    if (gt.HasOccluders()) truth->occluders = ReadMesh(gt.OccludersPath());
    std::vector<const TriangleMesh*> meshes{&truth->object};
    if (!truth->occluders.empty()) meshes.push_back(&truth->occluders);
    truth->caster = std::make_unique<RayCaster>(meshes);
    truth->views = gt.ReadHeldoutCameras();
  }
}

// The held-out renders' scores, accumulated render by render.
struct HeldoutScores {
  OrderedJson list = OrderedJson::array();  // metrics.json "heldout" / "renders"
  std::vector<double> psnr, rel;
  std::vector<double> contrast_object, contrast_surface;  // shadow contrast's relative errors per region
  int sun_renders = 0;                                    // renders under a held-out sky with a known sun
};

// Shadow contrast of held-out render `relit` (index.json entry `entry`; `ref` and `est` its images) under the
// sun `sun_dir_world`, over the true object's pixels and over the pixels the model covers; empty when the
// view has no true camera.
OrderedJson HeldoutShadowContrast(const EvaluateContext& ctx, const HeldoutTruth& truth, const Json& entry,
                                  const RenderRecord& relit, const Image& ref, const Image& est,
                                  const Eigen::Vector3d& sun_dir_world, HeldoutScores* scores) {
  const std::string view = entry.at("view").get<std::string>();
  const std::string name = view + "__" + entry.at("envmap").get<std::string>();
  const ImageRecord* pose = nullptr;
  for (const auto& [id, image] : truth.views.images)
    if (image.name == view) pose = &image;
  OrderedJson sc;
  if (!pose || !truth.views.cameras.count(pose->camera_id)) return sc;
  const Camera& camera = truth.views.cameras.at(pose->camera_id);
  const Image object = ReadMask(JoinPath(truth.dir, entry.at("mask").get<std::string>()));
  const Image covered = relit.mask.empty() ? Image() : ReadMask(JoinPath(ctx.inputs.relight_dir, relit.mask));
  for (const bool object_only : {true, false}) {
    const Image& region = object_only ? object : covered;
    if (camera.width != ref.width || camera.height != ref.height ||
        (!region.empty() && (region.width != ref.width || region.height != ref.height)))
      continue;
    const SunRegions regions = SunAndShadowRegions(*truth.caster, camera, *pose, sun_dir_world, region);
    const size_t lit_px = CountMask(regions.lit), shadow_px = CountMask(regions.shadow);
    if (std::min(lit_px, shadow_px) < kMinShadowRegionPixels) {
      sc[object_only ? "object" : "surface"] = {
          {"lit_pixels", lit_px},
          {"shadow_pixels", shadow_px},
          {"reason", "fewer than " + std::to_string(kMinShadowRegionPixels) + " sunlit or shadowed pixels"}};
      continue;
    }
    ShadowContrast s;
    try {
      s = MeasureShadowContrast(ref, est, regions, name);
    } catch (const UserError& e) {  // black shadows: no finite ratio; the other scores still count
      sc[object_only ? "object" : "surface"] = {{"reason", e.what()}};
      continue;
    }
    sc[object_only ? "object" : "surface"] = {{"lit_pixels", s.lit_pixels},
                                              {"shadow_pixels", s.shadow_pixels},
                                              {"reference_ratio", s.reference_ratio},
                                              {"relit_ratio", s.estimate_ratio},
                                              {"relative_error", s.relative_error}};
    (object_only ? scores->contrast_object : scores->contrast_surface).push_back(s.relative_error);
  }
  return sc;
}

// Scores held-out render `relit` against the ground truth's (index.json entry `entry`) into `scores`, and
// writes its figures into `figures`.
void ScoreHeldoutRender(const EvaluateContext& ctx, const HeldoutTruth& truth, const Json& entry,
                        const RenderRecord& relit, HeldoutScores* scores, OrderedJson* figures) {
  const EvaluateOptions& o = ctx.options;
  const std::string& dir = truth.dir;
  const std::string view = entry.at("view").get<std::string>(), env = entry.at("envmap").get<std::string>();
  const std::string name = view + "__" + env;
  const Image ref = ReadImage(JoinPath(dir, entry.at("image").get<std::string>()));
  const Image est = ReadImage(JoinPath(ctx.inputs.relight_dir, relit.exr));
  const Image mask = ErodeMask(ReadMask(JoinPath(dir, entry.at("mask").get<std::string>())), o.mask_erosion_px);
  OrderedJson j;
  j["name"] = name;
  j["view"] = view;
  j["envmap"] = env;
  if (CountMask(mask) == 0) {
    j["psnr_db"] = nullptr;
    j["reason"] = "empty object mask";
    scores->list.push_back(j);
    return;
  }
  const ImageComparison c = CompareScaleInvariant(ref, est, mask, ctx.compare, name);
  j.update(ComparisonJson(c));
  auto sun = truth.sun_by_envmap.find(env);
  scores->sun_renders += sun != truth.sun_by_envmap.end();
  if (sun != truth.sun_by_envmap.end() && truth.caster) {
    const OrderedJson sc = HeldoutShadowContrast(ctx, truth, entry, relit, ref, est, sun->second, scores);
    if (!sc.empty()) j["shadow_contrast"] = sc;
  }
  scores->list.push_back(j);
  scores->psnr.push_back(c.psnr_db);
  scores->rel.push_back(c.relative_rmse);
  const std::string base = "figures/heldout/" + name;
  WriteComparisonFigures(ref, est, mask, c, o, JoinPath(ctx.output_dir, base + "_reference.png"),
                         JoinPath(ctx.output_dir, base + "_relit.png"), JoinPath(ctx.output_dir, base + "_error.png"));
  OrderedJson f = {{"name", name},
                   {"reference", base + "_reference.png"},
                   {"relit", base + "_relit.png"},
                   {"error", base + "_error.png"},
                   {"psnr_db", c.psnr_db}};
  if (j.contains("shadow_contrast") && j["shadow_contrast"].contains("surface") &&
      j["shadow_contrast"]["surface"].contains("reference_ratio")) {
    f["shadow_ratio_reference"] = j["shadow_contrast"]["surface"]["reference_ratio"];
    f["shadow_ratio_relit"] = j["shadow_contrast"]["surface"]["relit_ratio"];
  }
  (*figures)["heldout"].push_back(f);
}

// The held-out metrics: relight's held-out views under held-out maps against the ground truth's renders, and
// shadow contrast under the maps' suns, into `metrics`; their figures into `figures`.
void ScoreHeldout(const EvaluateContext& ctx, OrderedJson* metrics, OrderedJson* figures) {
  OrderedJson& m = *metrics;
  std::string reason;
  if (!ctx.has_gt)
    reason = "no ground truth";
  else if (!ctx.truth.HasHeldout())
    reason = "the ground truth has no relight/index.json";
  else if (ctx.inputs.relight_dir.empty())
    reason = "the relight stage did not run";
  HeldoutScores scores;
  (*figures)["heldout"] = OrderedJson::array();
  if (reason.empty()) {
    const TrueHeldout heldout = ctx.truth.ReadHeldout();
    std::map<std::string, const RenderRecord*> by_name;
    for (const auto& r : ctx.renders)
      if (r.kind == "heldout") by_name[r.name] = &r;
    HeldoutTruth truth;
    LoadHeldoutTruth(ctx.truth, heldout, &truth);
    for (const auto& e : heldout.renders) {
      auto it = by_name.find(e.view + "__" + e.envmap);
      if (it == by_name.end()) continue;
      ScoreHeldoutRender(ctx, truth, e.entry, *it->second, &scores, figures);
    }
    if (scores.psnr.empty())
      reason =
          "the relight stage rendered none of the held-out views (relight.heldout off, or the "
          "frames could not be related: see relight_summary.json notes)";
  }
  m["heldout"] = {{"renders", scores.list}};
  if (scores.psnr.empty()) {
    NotAvailable(&m, "relight_psnr_db", reason);
  } else {
    m["relight_psnr_db"] = Mean(scores.psnr);
    m["heldout"]["relative_rmse"] = Mean(scores.rel);
  }
  auto mean_abs = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += std::abs(x);
    return s / v.size();
  };
  if (!scores.contrast_object.empty()) m["heldout"]["shadow_contrast_error_object"] = mean_abs(scores.contrast_object);
  if (!scores.contrast_surface.empty())
    m["shadow_contrast_error"] = mean_abs(scores.contrast_surface);
  else
    NotAvailable(&m, "shadow_contrast_error",
                 !reason.empty() ? reason
                 : scores.sun_renders == 0
                     ? "no held-out map is a sky with a known sun"
                     : "no held-out view under a sun shows " + std::to_string(kMinShadowRegionPixels) +
                           " sunlit and shadowed pixels of the model");
}

// The environment-map scores, accumulated photo by photo.
struct EnvmapScores {
  OrderedJson list = OrderedJson::array();        // metrics.json "envmaps" / "photos"
  std::vector<double> rel, angle_sky, angle_all;  // relative errors; direction errors [deg] under suns, of all
};

// Scores photo `photo`'s recovered map (`oct`; `photo` is its <inverse>/lighting.json entry) against its true
// map (`truth_photo`, the ground truth's lighting.json entry) in the truth's frame, over the upper hemisphere
// when `upper`, into `scores`; writes the figures of both and lists them in `figure`.
void ScoreEnvmap(const EvaluateContext& ctx, const Json& photo, const TruePhotoLighting& true_lighting,
                 const Image& oct, bool upper, OrderedJson* figure, EnvmapScores* scores) {
  const Json& truth_photo = true_lighting.entry;
  const GroundTruthFrame& frame = ctx.frame;
  const Json& p = photo;
  const std::string name = p.at("name").get<std::string>(), base = "figures/envmaps/" + Stem(name);
  const int n = oct.width;
  const EnvMap recovered = EnvMap::FromOctahedral(oct);
  const EnvMap truth = EnvMap::Load(true_lighting.envmap_latlong);
  const EnvMap recovered_truth_frame = frame.IsIdentity() ? recovered : frame.EnvToTruth(recovered);
  const Image est = frame.IsIdentity() ? oct : recovered_truth_frame.ToOctahedral(n);
  const Image tru = truth.ToOctahedral(n);
  const EnvMapComparison c = CompareEnvMaps(est, tru, upper);
  Eigen::Vector3d dir_est = BrightestLobeDirection(est);
  const Json& env = truth_photo.contains("environment") ? truth_photo.at("environment") : Json::object();
  const bool sky = env.value("source", "") == "sky" && env.contains("sun_dir_world");
  Eigen::Vector3d dir_true = BrightestLobeDirection(tru);
  // Under a sun sky the estimate is the sun of the daylight model the inverse stage fitted, if it did.
  const bool fitted_sun = sky && p.contains("sun");
  if (sky) {
    const auto s = env.at("sun_dir_world").get<std::vector<double>>();
    dir_true = Eigen::Vector3d(s[0], s[1], s[2]);
    if (fitted_sun) {
      const auto e = p.at("sun").at("direction_world").get<std::vector<double>>();
      dir_est = frame.rotation() * Eigen::Vector3d(e[0], e[1], e[2]);
    }
  }
  const double angle = AngleDeg(dir_est, dir_true);
  scores->rel.push_back(c.relative_error);
  scores->angle_all.push_back(angle);
  if (sky) scores->angle_sky.push_back(angle);
  scores->list.push_back({{"name", name},
                          {"relative_error", c.relative_error},
                          {"scale", Vec(c.scale)},
                          {"light_dir_error_deg", angle},
                          {"truth_direction_from", sky ? "sun" : "brightest lobe of the true map"},
                          {"direction_from", fitted_sun ? "fitted sun" : "brightest lobe"},
                          {"direction_world", Vec(dir_est)},
                          {"true_direction_world", Vec(dir_true)}});
  // Figures in the truth's frame, the recovered map scaled to the truth, one exposure.
  const std::string& output_dir = ctx.output_dir;
  OrderedJson& f = *figure;
  const Image truth_ll = truth.ToLatLong(64, 2);
  const double exposure = PercentileExposure(truth_ll, nullptr, 99);
  WritePng(JoinPath(output_dir, base + "_oct.png"), ToneMapSrgb(ScaleChannels(est, c.scale), exposure));
  WritePng(JoinPath(output_dir, base + "_latlong.png"),
           ToneMapSrgb(ScaleChannels(recovered_truth_frame.ToLatLong(64, 2), c.scale), exposure));
  WritePng(JoinPath(output_dir, base + "_truth_oct.png"), ToneMapSrgb(tru, exposure));
  WritePng(JoinPath(output_dir, base + "_truth_latlong.png"), ToneMapSrgb(truth_ll, exposure));
  f["frame"] = "truth";
  f["truth_oct"] = base + "_truth_oct.png";
  f["truth_latlong"] = base + "_truth_latlong.png";
  f["relative_error"] = c.relative_error;
  f["light_dir_error_deg"] = angle;
}

// The environment-map metrics: each photo's recovered map against the true one, and the brightest
// directions, into `metrics`; the maps' figures (in the model's frame when there is no truth) into `figures`.
void ScoreEnvmaps(const EvaluateContext& ctx, OrderedJson* metrics, OrderedJson* figures) {
  const EvaluateOptions& o = ctx.options;
  const EvaluateInputs& in = ctx.inputs;
  const GroundTruth& gt = ctx.truth;
  const bool has_gt = ctx.has_gt;
  OrderedJson& m = *metrics;
  OrderedJson& fig = *figures;
  fig["envmaps"] = OrderedJson::array();
  const std::string lighting_path = in.inverse_dir.empty() ? "" : JoinPath(in.inverse_dir, "lighting.json");
  const bool has_truth = has_gt && gt.HasLighting();
  std::string reason;
  if (!IsFile(lighting_path))
    reason = "the inverse stage did not run";
  else if (!has_truth)
    reason = has_gt ? "the ground truth has no lighting.json" : "no ground truth";
  else if (!ctx.frame.available)
    reason = "the model's frame could not be related to the ground truth: " + ctx.frame.reason;
  bool upper = o.envmap_region == "upper";
  if (o.envmap_region == "auto") upper = has_gt && gt.HasOccluders();
  std::map<std::string, TruePhotoLighting> truth_by_name;
  if (has_truth)
    for (auto& p : gt.ReadLighting()) truth_by_name[p.name] = std::move(p);
  EnvmapScores scores;
  if (IsFile(lighting_path)) {
    const Json lighting = ReadJsonFile(lighting_path);
    for (const auto& p : lighting.at("photos")) {
      const std::string name = p.at("name").get<std::string>(), stem = Stem(name);
      const Image oct = ReadImage(JoinPath(in.inverse_dir, p.at("envmap_oct").get<std::string>()));
      const std::string base = "figures/envmaps/" + stem;
      OrderedJson f{{"name", name}};
      auto it = truth_by_name.find(name);
      if (reason.empty() && it != truth_by_name.end()) {
        ScoreEnvmap(ctx, p, it->second, oct, upper, &f, &scores);
      } else {
        const Image ll = EnvMap::FromOctahedral(oct).ToLatLong(64, 2);
        const double exposure = PercentileExposure(ll, nullptr, 99);
        WritePng(JoinPath(ctx.output_dir, base + "_oct.png"), ToneMapSrgb(oct, exposure));
        WritePng(JoinPath(ctx.output_dir, base + "_latlong.png"), ToneMapSrgb(ll, exposure));
        f["frame"] = "model";
      }
      f["oct"] = base + "_oct.png";
      f["latlong"] = base + "_latlong.png";
      fig["envmaps"].push_back(f);
    }
  }
  const std::vector<double>&rel = scores.rel, &angle_sky = scores.angle_sky, &angle_all = scores.angle_all;
  m["envmaps"] = {{"region", upper ? "upper hemisphere (z > 0)" : "sphere"}, {"photos", scores.list}};
  if (rel.empty()) {
    NotAvailable(&m, "envmap_rel_error", reason.empty() ? "no photo has a true environment map" : reason);
  } else {
    m["envmap_rel_error"] = Mean(rel);
    m["envmaps"]["median_relative_error"] = Median(rel);
  }
  if (!angle_all.empty()) {
    m["light_dir_error_deg"] = Median(angle_sky.empty() ? angle_all : angle_sky);
    m["envmaps"]["light_dir_error_from"] =
        angle_sky.empty() ? "all photos (brightest lobe of the true map)" : "photos under a sun sky (sun direction)";
    m["envmaps"]["light_dir_error_deg_all_photos"] = Median(angle_all);
    m["envmaps"]["light_dir_error_deg_sky_photos"] =
        angle_sky.empty() ? OrderedJson(nullptr) : OrderedJson(Median(angle_sky));
  }
}

// DiLiGenT-style known directional lights (<gt>/lights.json) against the recovered light, into `metrics`; their
// median angle error is the light direction error when the environment maps gave none.
void ScoreDirectionalLights(const EvaluateContext& ctx, OrderedJson* metrics) {
  OrderedJson& m = *metrics;
  const GroundTruth& gt = ctx.truth;
  if (ctx.has_gt && gt.HasLights() && !ctx.inputs.inverse_dir.empty()) {
    const LightEvaluation e = EvaluateDirectionalLights(ctx.inputs.inverse_dir, ReadDirectionalLights(gt.LightsPath()));
    OrderedJson per = OrderedJson::array();
    for (size_t k = 0; k < e.photos.size(); ++k)
      per.push_back({{"name", e.photos[k]},
                     {"angle_error_deg", e.angle_error_deg[k]},
                     {"power_rgb", Vec(e.power_rgb[k])},
                     {"true_rgb", Vec(e.true_rgb[k])}});
    m["directional_lights"] = {{"median_angle_deg", e.median_angle_deg},
                               {"p90_angle_deg", e.p90_angle_deg},
                               {"pearson_rgb", Vec(e.pearson)},
                               {"relative_intensity_rmse", e.relative_intensity_rmse},
                               {"photos", per}};
    if (m["light_dir_error_deg"].is_null()) {
      m["light_dir_error_deg"] = e.median_angle_deg;
      m["not_available"].erase("light_dir_error_deg");
    }
  } else if (m["light_dir_error_deg"].is_null()) {
    NotAvailable(&m, "light_dir_error_deg",
                 ctx.has_gt ? "the ground truth has neither lighting.json nor lights.json (or the frames are unrelated)"
                            : "no ground truth");
  }
}

// The mesh's albedo_r/g/b vertex properties (null where absent).
std::array<const std::vector<float>*, 3> AlbedoProperties(const TriangleMesh& mesh) {
  return {mesh.FindProperty("albedo_r"), mesh.FindProperty("albedo_g"), mesh.FindProperty("albedo_b")};
}

// Recovered (scaled by `scale`) beside true albedo, rendered from relight's albedo cameras into the albedo
// figures.
void WriteAlbedoFigures(const EvaluateContext& ctx, const TriangleMesh& model_mesh, const TriangleMesh& truth_mesh,
                        const Eigen::Vector3d& scale, OrderedJson* figures) {
  const Eigen::Vector3d& s = scale;
  const auto ea = AlbedoProperties(model_mesh), ta = AlbedoProperties(truth_mesh);
  std::vector<Eigen::Vector3f> est_rgb(model_mesh.num_vertices()), true_rgb(truth_mesh.num_vertices());
  for (size_t v = 0; v < model_mesh.num_vertices(); ++v)
    for (int c = 0; c < 3; ++c) est_rgb[v][c] = float(s[c] * (*ea[c])[v]);
  for (size_t v = 0; v < truth_mesh.num_vertices(); ++v)
    for (int c = 0; c < 3; ++c) true_rgb[v][c] = (*ta[c])[v];
  const RayCaster model_caster({&model_mesh}), truth_caster({&truth_mesh});
  const Eigen::Vector3f grey = Eigen::Vector3f::Constant(0.18f);
  for (const auto& r : ctx.renders) {
    if (r.kind != "albedo") continue;
    const std::string base = "figures/albedo/" + r.name;
    WritePng(JoinPath(ctx.output_dir, base + "_recovered.png"),
             ToneMapSrgb(RenderVertexColors(model_caster, 0, est_rgb, r.camera.camera, r.camera.pose, grey), 1));
    WritePng(JoinPath(ctx.output_dir, base + "_truth.png"),
             ToneMapSrgb(RenderVertexColors(truth_caster, 0, true_rgb, r.camera.camera,
                                            ctx.frame.PoseToTruth(r.camera.pose), grey),
                         1));
    (*figures)["albedo"].push_back(
        {{"view", r.view}, {"recovered", base + "_recovered.png"}, {"truth", base + "_truth.png"}});
  }
}

// Recovered and true albedo of the observed model vertices, paired by the true surface each lies on.
struct AlbedoPairs {
  std::vector<Eigen::Vector3d> t, e;                      // on the true object: true and recovered albedo
  std::vector<Eigen::Vector3d> confident_t, confident_e;  // of those, the ones two photos see with confidence
  std::vector<Eigen::Vector3d> around_t, around_e;        // on the true surroundings (occluders.ply)
  size_t off_surface = 0;                                 // vertices off every true surface
};

// Pairs the observed vertices of `model_mesh` with the true albedo: vertex by vertex when `same` (the model's
// mesh is the true one), else at the closest point of the true surfaces.
AlbedoPairs PairAlbedo(const EvaluateContext& ctx, const TriangleMesh& truth_mesh, const TriangleMesh& model_mesh,
                       bool same) {
  const ObservationSet& observations = ctx.observations;
  // Observed vertices, and how many photos see each with confidence (α >= 0.5).
  std::vector<char> seen(model_mesh.num_vertices(), 0);
  std::vector<int> confident_photos(model_mesh.num_vertices(), 0);
  for (const auto& ob : observations.records) {
    if (ob.vertex >= seen.size() || ob.lower_bound()) continue;
    seen[ob.vertex] = 1;
    confident_photos[ob.vertex] += ob.confidence >= 0.5f;
  }
  if (observations.records.empty()) std::fill(seen.begin(), seen.end(), 1);
  const TriangleMesh model_in_truth = ctx.frame.MeshToTruth(model_mesh);
  // A reconstruction also covers what surrounds the object (the ground): each of its vertices is
  // scored against the true surface it lies on, the object's (mesh.ply) or, when the truth gives
  // their albedo, the surroundings' (occluders.ply), and left out when it is farther than 2% of
  // the object's diagonal from both (off every true surface). Where the two touch, the object's.
  TriangleMesh truth_surroundings;
  const std::string surroundings_path = ctx.truth.OccludersPath();
  if (!same && IsFile(surroundings_path)) {
    truth_surroundings = ReadMesh(surroundings_path);
    for (const char* p : {"albedo_r", "albedo_g", "albedo_b"})
      if (!truth_surroundings.FindProperty(p)) truth_surroundings = TriangleMesh();
    if (!(truth_surroundings.SurfaceArea() > 0)) truth_surroundings = TriangleMesh();  // nothing to lie on
  }
  std::unique_ptr<SurfaceIndex> index, surroundings_index;
  if (!same) index = std::make_unique<SurfaceIndex>(truth_mesh);
  if (!truth_surroundings.empty()) surroundings_index = std::make_unique<SurfaceIndex>(truth_surroundings);
  const double tolerance = 0.02 * truth_mesh.BoundingBox().diagonal().norm();
  const auto ta = AlbedoProperties(truth_mesh), ga = AlbedoProperties(truth_surroundings),
             ea = AlbedoProperties(model_mesh);
  AlbedoPairs pairs;
  for (size_t v = 0; v < model_mesh.num_vertices(); ++v) {
    if (!seen[v]) continue;
    const Eigen::Vector3d ev((*ea[0])[v], (*ea[1])[v], (*ea[2])[v]);
    Eigen::Vector3d tv;
    bool on_object = true;
    if (same) {
      for (int c = 0; c < 3; ++c) tv[c] = (*ta[c])[v];
    } else {
      const Eigen::Vector3d p = model_in_truth.vertices[v].cast<double>();
      ClosestPoint cp = index->Query(p);
      if (surroundings_index) {
        const ClosestPoint gp = surroundings_index->Query(p);
        if (gp.distance < cp.distance - 1e-3 * tolerance) {  // where they touch, the object's
          cp = gp;
          on_object = false;
        }
      }
      if (cp.distance > tolerance) {
        ++pairs.off_surface;
        continue;
      }
      const SurfaceIndex& from = on_object ? *index : *surroundings_index;
      for (int c = 0; c < 3; ++c) tv[c] = from.Interpolate(cp, on_object ? *ta[c] : *ga[c]);
    }
    if (!on_object) {
      pairs.around_t.push_back(tv);
      pairs.around_e.push_back(ev);
      continue;
    }
    pairs.t.push_back(tv);
    pairs.e.push_back(ev);
    if (confident_photos[v] >= 2) {
      pairs.confident_t.push_back(tv);
      pairs.confident_e.push_back(ev);
    }
  }
  return pairs;
}

// The albedo metrics (docs/METRICS.md "Albedo") into `metrics`, and the albedo figures from relight's
// albedo cameras into `figures`.
void EvaluateAlbedo(const EvaluateContext& ctx, OrderedJson* metrics, OrderedJson* figures) {
  const EvaluateInputs& in = ctx.inputs;
  const GroundTruthFrame& frame = ctx.frame;
  OrderedJson& m = *metrics;
  (*figures)["albedo"] = OrderedJson::array();
  std::string reason;
  const std::string truth_path = ctx.truth.MeshPath();
  if (!ctx.has_gt || !IsFile(truth_path))
    reason = ctx.has_gt ? "the ground truth has no mesh.ply" : "no ground truth";
  else if (in.inverse_dir.empty())
    reason = "the inverse stage did not run";
  else if (!frame.available)
    reason = "the model's frame could not be related to the ground truth: " + frame.reason;
  TriangleMesh truth_mesh, model_mesh;
  if (reason.empty()) {
    truth_mesh = ReadMesh(truth_path);
    model_mesh = ReadMesh(JoinPath(in.inverse_dir, "reflectance.ply"));
    for (const char* p : {"albedo_r", "albedo_g", "albedo_b"}) {
      if (!truth_mesh.FindProperty(p))
        reason = "the ground-truth mesh has no albedo_r/g/b";
      else if (!model_mesh.FindProperty(p))
        reason = "reflectance.ply has no albedo_r/g/b";
    }
    if (reason.empty() && !(truth_mesh.SurfaceArea() > 0)) reason = "'" + truth_path + "' has no surface area";
  }
  if (reason.empty()) {
    const std::string mesh_source = ReadMeshSource(in.mesh_dir);
    const bool same =
        mesh_source == "ground_truth" && truth_mesh.num_vertices() == model_mesh.num_vertices() && frame.IsIdentity();
    const AlbedoPairs pairs = PairAlbedo(ctx, truth_mesh, model_mesh, same);
    if (pairs.t.empty()) {
      reason = "no observed vertex lies on the true object";
    } else {
      const AlbedoScore object = ScoreAlbedo(pairs.t, pairs.e),
                        confident = ScoreAlbedo(pairs.confident_t, pairs.confident_e),
                        around = ScoreAlbedo(pairs.around_t, pairs.around_e);
      const Eigen::Vector3d& s = object.scale;
      m["albedo_psnr_db"] = object.psnr_db;
      m["albedo"] = {{"vertices", pairs.t.size()},
                     {"correspondence", same ? "same mesh" : "closest point on the true surfaces"},
                     {"scale", Vec(s)},
                     {"rmse", object.rmse},
                     {"peak", 1.0},
                     {"confident_vertices", confident.vertices},
                     {"confident_psnr_db", confident.vertices > 0 ? OrderedJson(confident.psnr_db) : OrderedJson()},
                     {"surroundings_vertices", around.vertices},
                     {"surroundings_psnr_db", around.vertices > 0 ? OrderedJson(around.psnr_db) : OrderedJson()},
                     {"off_surface_vertices", pairs.off_surface}};
      // Recovered (scaled) beside true albedo from relight's albedo cameras.
      if (ctx.caster) WriteAlbedoFigures(ctx, model_mesh, truth_mesh, s, figures);
    }
  }
  if (!reason.empty()) NotAvailable(&m, "albedo_psnr_db", reason);
}

// The sfm stage's cameras against the true ones (when it estimated them) into `metrics`.
void ScoreCameras(const EvaluateContext& ctx, OrderedJson* metrics) {
  OrderedJson& m = *metrics;
  const GroundTruthFrame& frame = ctx.frame;
  if (frame.has_camera_errors) {
    const CameraErrors& c = frame.camera_errors;
    m["cameras"] = {{"matched", c.matched},
                    {"missing", c.missing},
                    {"median_rotation_deg", c.median_rotation_deg},
                    {"max_rotation_deg", c.max_rotation_deg},
                    {"median_center_error", c.median_center_error},
                    {"median_center_error_relative", c.median_center_error_relative},
                    {"scene_radius", c.scene_radius}};
  } else {
    m["not_available"]["cameras"] = !ctx.has_gt       ? "no ground truth"
                                    : frame.available ? "the sfm stage used the ground-truth cameras"
                                                      : frame.reason;
  }
}

// The reconstructed mesh against the true one (Chamfer distances; docs/METRICS.md "Geometry") into `metrics`.
void ScoreMesh(const EvaluateContext& ctx, OrderedJson* metrics) {
  OrderedJson& m = *metrics;
  const GroundTruth& gt = ctx.truth;
  const TriangleMesh& mesh = ctx.mesh;
  const GroundTruthFrame& frame = ctx.frame;
  const std::string mesh_source = ReadMeshSource(ctx.inputs.mesh_dir);
  const std::string truth_path = gt.MeshPath();
  if (ctx.has_gt && IsFile(truth_path) && !mesh.empty() && frame.available && mesh_source != "ground_truth") {
    const TriangleMesh truth_mesh = ReadMesh(truth_path);
    // The true ground and blockers (synthetic scenes): reconstructed ground is not an error.
    const TriangleMesh context = gt.HasOccluders() ? ReadMesh(gt.OccludersPath()) : TriangleMesh();
    const MeshDistances d = CompareMeshes(frame.MeshToTruth(mesh), truth_mesh, size_t(ctx.options.mesh_samples), 1,
                                          context.num_faces() > 0 ? &context : nullptr);
    m["mesh"] = {{"source", mesh_source},
                 {"diagonal", d.diagonal},
                 {"chamfer_relative", d.chamfer / d.diagonal},
                 {"accuracy_mean_relative", d.accuracy_mean / d.diagonal},
                 {"completeness_mean_relative", d.completeness_mean / d.diagonal},
                 {"accuracy_p90_relative", d.accuracy_p90 / d.diagonal},
                 {"completeness_p90_relative", d.completeness_p90 / d.diagonal},
                 {"samples", d.samples},
                 {"estimate_samples_near_object", d.estimate_samples_near_object},
                 {"accuracy_region", context.num_faces() > 0 ? "object bounding box + 10%, vs object and occluders"
                                                             : "whole estimate, vs object"}};
  } else {
    m["not_available"]["mesh"] = !ctx.has_gt || !IsFile(truth_path) ? "no ground-truth mesh"
                                 : mesh.empty()                     ? "the mesh stage did not run"
                                 : !frame.available                 ? frame.reason
                                                                    : "the mesh is the ground truth's";
  }
}

// What every leave-one-out fold uses.
struct LeaveOneOutSetup {
  InverseOptions inverse_options;  // the inverse stage's resolved options
  InverseOptions group_options;    // of the solves from scratch: only the start the full solve kept
  int fold_iterations = 0;         // outer iterations of a fold started from its group's reflectance
  InverseProblem problem;
  RecoveredModel full;             // the full solve's model: its occluders and their albedo
  RelightOptions relight_options;  // the relight stage's: the renderer and samples of its re-renderings
  std::map<std::string, const RenderRecord*> rerender;  // relight's re-rendering of each photo, by photo name
};

// The leave-one-out scores, accumulated photo by photo.
struct LeaveOneOutScores {
  OrderedJson list = OrderedJson::array();     // metrics.json "leave_one_out" / "photos"
  OrderedJson figures = OrderedJson::array();  // figures.json "loo"
  std::vector<double> psnr;
  std::set<std::string> scored;  // photos with a leave-one-out score
};

// The inverse options of the solves from scratch: the inverse stage's, with only the start its full solve kept.
InverseOptions GroupSolveOptions(const std::string& inverse_dir, const InverseOptions& inverse_options) {
  // Solves from scratch run only the start the full solve kept (inverse.init_gloss): one discrete choice
  // made with the held-out photos, against the cost of racing every start again in every group.
  InverseOptions group_options = inverse_options;
  if (const std::string path = JoinPath(inverse_dir, "solve_summary.json"); IsFile(path)) {
    for (const auto& st : ReadJsonFile(path).value("starts", Json::array()))
      if (st.value("chosen", false) && inverse_options.init_gloss.size() > 1)
        group_options.init_gloss = {st.value("init_gloss", inverse_options.init_gloss.front())};
  }
  return group_options;
}

// Fold `fit` (photo `photo` left out) rendered from relight's camera `r` of the photo, as the relight stage
// renders its re-renderings (same renderer and samples).
RenderedView RenderFold(const LeaveOneOutSetup& setup, const LeaveOneOutFit& fit, const RenderRecord& r,
                        uint32_t photo) {
  const RelightOptions& relight_options = setup.relight_options;
  const RecoveredModel& full = setup.full;
  TriangleMesh weighted = setup.problem.mesh;
  const int nm = fit.reflectance.num_materials;
  for (int mm = 0; mm < nm; ++mm) {
    std::vector<float>& w = weighted.Property("w" + std::to_string(mm));
    for (size_t v = 0; v < weighted.num_vertices(); ++v) w[v] = fit.reflectance.weights[v * nm + mm];
  }
  // With inverse.interreflection the fold is rendered with the bounce and occluder albedo it was fitted with.
  RecoveredModel fold = full;
  if (setup.inverse_options.interreflection == "mesh_and_occluders" && fit.reflectance.occluder_albedo.maxCoeff() > 0)
    fold.occluder_albedo = fit.reflectance.occluder_albedo;
  const Scene scene(ModelSurfaces(weighted, fit.reflectance.Model(), full.occluders,
                                  fold.OccluderAlbedo(relight_options.occluder_albedo)),
                    "leave-one-out model");
  const Image map = relight_options.zero_unseen_light
                        ? ZeroTexels(fit.lighting_oct, UnseenOctTexels(scene, fit.lighting_oct.width))
                        : fit.lighting_oct;
  const Lighting lighting = Lighting::FromEnvMap(EnvMap::FromOctahedral(map));
  RenderedView view;
  if (relight_options.renderer == "transport") {
    TransportRenderer renderer(scene, setup.problem.visibility, fit.lighting_oct.width);
    EnableModelInterreflection(fold, &renderer, nullptr);
    TransportRenderOptions to;
    to.pixel_samples_per_axis = relight_options.pixel_samples_per_axis;
    to.background = false;
    view = renderer.Render(lighting, r.camera.camera, r.camera.pose, to);
  } else {
    RenderOptions ro;
    ro.pixel_samples_per_axis = relight_options.pixel_samples_per_axis;
    ro.light_samples = std::max(relight_options.light_samples, relight_options.scored_samples);
    ro.brdf_samples = std::max(relight_options.brdf_samples, relight_options.scored_samples);
    ro.background = false;
    ro.seed = MixSeed(1, 0x100 + photo);
    EnableModelInterreflection(fold, nullptr, &ro);
    view = RenderView(scene, lighting, r.camera.camera, r.camera.pose, ro, photo);
  }
  return view;
}

// Scores the render `view` of fold `fit` (photo `photo`, relight's re-rendering `r`) against the linear photo
// into `scores`, with its figures; `group_solve_seconds` is the group's solve from scratch (null: none).
void ScoreFold(const EvaluateContext& ctx, uint32_t photo, const RenderRecord& r, const LeaveOneOutFit& fit,
               const RenderedView& view, const OrderedJson& group_solve_seconds, LeaveOneOutScores* scores) {
  const EvaluateOptions& o = ctx.options;
  const std::string& name = r.view;  // the photo's name (re-renderings are named by their photo)
  OrderedJson e{{"name", name}};
  const PhotoReference ref =
      LoadPhotoReference(ctx.inputs.linearize_dir, r.name, view.radiance.width, view.radiance.height);
  const Image mask = ComparisonMask(
      ObservedPixelMask(*ctx.caster, ObservedVertices(ctx.observations, photo), r.camera.camera, r.camera.pose), ref,
      o);
  if (CountMask(mask) == 0) {
    e["psnr_db"] = nullptr;
    e["reason"] = "no observed, unclipped pixel";
    scores->list.push_back(e);
    return;
  }
  const ImageComparison c = CompareScaleInvariant(ref.linear, view.radiance, mask, ctx.compare, name);
  e.update(ComparisonJson(c));
  e["seconds"] = fit.seconds + view.seconds;
  e["group_solve_seconds"] = group_solve_seconds;  // shared by the group
  e["reflectance_iterations"] = fit.reflectance_summary.iterations.size();
  e["observation_rmse"] = fit.photo_rmse;
  scores->list.push_back(e);
  scores->psnr.push_back(c.psnr_db);
  scores->scored.insert(name);
  const std::string base = "figures/loo/" + r.name;
  const double exposure = PercentileExposure(ref.linear, &mask, 99);
  WritePng(JoinPath(ctx.output_dir, base + "_render.png"),
           ToneMapSrgb(ScaleChannels(view.radiance, c.scale), exposure));
  WritePng(JoinPath(ctx.output_dir, base + "_error.png"),
           HeatMap(RelativeErrorImage(ref.linear, view.radiance, c.scale, c.peak), o.heatmap_max, &mask));
  scores->figures.push_back(
      {{"name", name}, {"render", base + "_render.png"}, {"error", base + "_error.png"}, {"psnr_db", c.psnr_db}});
  RLOG_INFO("leave-one-out {}: PSNR {:.2f} dB ({:.1f} s)", name, c.psnr_db, fit.seconds + view.seconds);
}

// Solves without each scored photo (evaluate/leave_one_out.h), renders it under the fold's light and scores it
// into `scores`.
void RunLeaveOneOutFolds(const EvaluateContext& ctx, LeaveOneOutScores* scores) {
  const EvaluateOptions& o = ctx.options;
  const EvaluateInputs& in = ctx.inputs;
  LeaveOneOutSetup setup;
  if (!ReadResolvedOptions(in.inverse_dir, "inverse", &setup.inverse_options))
    RLOG_WARN("no {}/config.yaml: leave-one-out uses the inverse stage's default options", in.inverse_dir);
  InverseProblem& problem = setup.problem;
  problem = LoadInverseProblem(in.mesh_dir, in.visibility_dir, in.observe_dir);
  problem.scratch_dir = ctx.output_dir;
  // The model's occluders, prepared as the relight stage renders them.
  setup.full = LoadRecoveredModel(in.inverse_dir, in.mesh_dir);
  // Render the held-out photo as the relight stage renders its re-renderings (same renderer and samples).
  ReadResolvedOptions(in.relight_dir, "relight", &setup.relight_options);
  for (const auto& r : ctx.renders)
    if (r.kind == "rerender") setup.rerender[r.view] = &r;
  std::vector<uint32_t> chosen;
  for (uint32_t i : SpreadPhotos(problem.observations.num_photos, o.loo_max_photos)) {
    if (setup.rerender.count(problem.photos[i].name)) {
      chosen.push_back(i);
    } else {
      scores->list.push_back({{"name", problem.photos[i].name},
                              {"psnr_db", nullptr},
                              {"reason", "the relight stage did not re-render this photo"}});
    }
  }
  // Groups left out together (evaluate/leave_one_out.h): one solve from scratch per group, then a short
  // fold per photo started from it; a group of one is a fold from scratch.
  const std::vector<std::vector<uint32_t>> groups = LeaveOutGroups(chosen, problem.observations.num_photos);
  setup.fold_iterations = o.loo_max_iterations > 0 ? o.loo_max_iterations : setup.inverse_options.max_iterations;
  setup.group_options = GroupSolveOptions(in.inverse_dir, setup.inverse_options);
  RLOG_INFO(
      "leave-one-photo-out: {} photo(s) in {} group(s) left out together; a solve from scratch per group, "
      "then {} iterations per photo",
      chosen.size(), groups.size(), setup.fold_iterations);
  Progress progress("leave-one-photo-out", static_cast<int64_t>(chosen.size() + groups.size()));
  for (const std::vector<uint32_t>& group : groups) {
    Timer group_timer;
    ReflectanceState group_start;
    if (group.size() > 1) group_start = SolveWithout(&problem, setup.group_options, group);
    const double group_seconds = group_timer.Seconds();
    progress.Advance();
    for (uint32_t i : group) {
      const RenderRecord& r = *setup.rerender.at(problem.photos[i].name);
      const LeaveOneOutFit fit =
          group.size() > 1 ? LeaveOneOut(&problem, setup.inverse_options, i, setup.fold_iterations, &group_start)
                           : LeaveOneOut(&problem, setup.group_options, i, 0);
      const RenderedView view = RenderFold(setup, fit, r, i);
      progress.Advance();
      ScoreFold(ctx, i, r, fit, view, group.size() > 1 ? OrderedJson(group_seconds) : OrderedJson(), scores);
    }
  }
}

// The leave-one-photo-out metrics (docs/METRICS.md "Leave-one-photo-out") into `metrics`, their figures into
// `figures`; run by evaluate.leave_one_out (by default only without ground-truth light).
void ScoreLeaveOneOut(const EvaluateContext& ctx, OrderedJson* metrics, OrderedJson* figures) {
  const EvaluateOptions& o = ctx.options;
  const EvaluateInputs& in = ctx.inputs;
  const GroundTruth& gt = ctx.truth;
  OrderedJson& m = *metrics;
  const bool gt_light = ctx.has_gt && (gt.HasHeldout() || gt.HasLighting() || gt.HasLights());
  const bool run = o.leave_one_out == "always" || (o.leave_one_out == "auto" && !gt_light);
  std::string reason;
  if (!run) {
    reason = o.leave_one_out == "never" ? "evaluate.leave_one_out is never"
                                        : "the ground truth knows the light (evaluate.leave_one_out: always to run it)";
  } else if (in.visibility_dir.empty() || in.observe_dir.empty() || in.inverse_dir.empty() || !ctx.caster ||
             in.linearize_dir.empty()) {
    reason = "the mesh, linearize, visibility, observe and inverse stages must all have run";
  }
  LeaveOneOutScores scores;
  if (reason.empty()) {
    RunLeaveOneOutFolds(ctx, &scores);
    if (scores.psnr.empty()) reason = "no scored photo could be rendered";
  }
  (*figures)["loo"] = scores.figures;
  const std::vector<double>& psnr = scores.psnr;
  m["leave_one_out"] = {{"photos", scores.list}};
  if (psnr.empty()) {
    NotAvailable(&m, "loo_psnr_db", reason);
  } else {
    m["loo_psnr_db"] = Mean(psnr);
    // The re-rendering score of the same photos, so that the two headline numbers compare like with like.
    std::vector<double> same;
    for (const auto& p : m["rerender"]["photos"])
      if (scores.scored.count(p.value("name", "")) && p.contains("psnr_db") && p["psnr_db"].is_number())
        same.push_back(p["psnr_db"].get<double>());
    m["leave_one_out"]["rerender_psnr_db"] = same.size() == psnr.size() ? OrderedJson(Mean(same)) : OrderedJson();
  }
}

// The wall-clock seconds of every upstream stage and of this one (`total`), and their sum, into the metrics.
void RecordSeconds(const EvaluateInputs& in, const Timer& total, EvaluateSummary* summary) {
  OrderedJson& m = summary->metrics;
  std::map<std::string, std::string> inputs;
  for (const auto& [name, dir] : std::map<std::string, std::string>{{"ingest", in.ingest_dir},
                                                                    {"sfm", in.sfm_dir},
                                                                    {"mesh", in.mesh_dir},
                                                                    {"linearize", in.linearize_dir},
                                                                    {"observe", in.observe_dir},
                                                                    {"visibility", in.visibility_dir},
                                                                    {"inverse", in.inverse_dir},
                                                                    {"relight", in.relight_dir}})
    if (!dir.empty()) inputs[name] = dir;
  m["seconds"] = CollectStageSeconds(inputs);
  summary->seconds = total.Seconds();
  m["seconds"]["evaluate"] = summary->seconds;
  double sum = 0;
  for (const auto& [k, v] : m["seconds"].items()) sum += v.get<double>();
  m["seconds"]["total"] = sum;
}

}  // namespace

EvaluateSummary RunEvaluate(const EvaluateOptions& o, const EvaluateInputs& in, const std::string& output_dir) {
  o.Check();
  Timer total;
  EvaluateSummary summary;
  OrderedJson& m = summary.metrics;
  OrderedJson& fig = summary.figures;
  StartOutputs(o, output_dir, &m, &fig);
  EvaluateContext ctx(o, in, output_dir);
  RelateToTruth(&ctx, &m);
  LoadSharedInputs(&ctx);

  ScoreRerenders(ctx, &m, &fig);
  ScoreHeldout(ctx, &m, &fig);
  ScoreEnvmaps(ctx, &m, &fig);
  ScoreDirectionalLights(ctx, &m);
  EvaluateAlbedo(ctx, &m, &fig);
  ScoreCameras(ctx, &m);
  ScoreMesh(ctx, &m);
  ScoreLeaveOneOut(ctx, &m, &fig);

  RecordSeconds(in, total, &summary);
  WriteJsonAtomic(JoinPath(output_dir, "metrics.json"), m);
  WriteJsonAtomic(JoinPath(output_dir, "figures.json"), fig);
  return summary;
}

}  // namespace relight
