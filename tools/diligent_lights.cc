// diligent_lights: recovered environment maps of a DiLiGenT run against the
// known directional lights (datasets/light_evaluation.h), and a figure of a
// few maps beside the true light positions.
//
//   diligent_lights --lights GT/lights.json INVERSE_DIR [INVERSE_DIR ...]
//                   [--json OUT.json] [--per-photo]
//                   [--figure OUT.png --photos 001.png,040.png --cell 160]
//
// Each INVERSE_DIR is an `inverse` stage output (lighting.json + envmaps/).
// The figure has one row per INVERSE_DIR and one column per photo; a cell
// shows the hemisphere of the map that faces the camera (orthographic, image
// right = world +X, up = world +Z), each cell scaled to its own brightest
// texel and sRGB-encoded, with the true light as a green ring and the
// recovered brightest-lobe direction as a red cross.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "datasets/light_evaluation.h"
#include "image/image.h"
#include "sphere/envmap.h"
#include "sphere/octahedral.h"

namespace relight {
namespace {

float EncodeSrgb(float v) {
  v = std::clamp(v, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

// Camera-facing hemisphere disc: pixel -> world direction (the camera looks along +Y).
bool DiscDirection(double u, double v, Eigen::Vector3d* d) {
  const double r2 = u * u + v * v;
  if (r2 > 1) return false;
  *d = Eigen::Vector3d(u, -std::sqrt(1 - r2), v);
  return true;
}

void DrawCell(const Image& oct, const Eigen::Vector3d& truth, const Eigen::Vector3d& found, int size, int x0, int y0,
              Image* canvas) {
  float peak = 1e-30f;
  for (float v : oct.pixels) peak = std::max(peak, v);
  const int n = oct.width;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const double u = 2.0 * (x + 0.5) / size - 1, v = 1 - 2.0 * (y + 0.5) / size;
      Eigen::Vector3d d;
      if (!DiscDirection(u, v, &d)) continue;
      const Eigen::Vector2i t = OctTexelOf(d, n);
      for (int c = 0; c < 3; ++c) canvas->at(x0 + x, y0 + y, c) = EncodeSrgb(oct.at(t.x(), t.y(), c) / peak);
    }
  auto to_px = [&](const Eigen::Vector3d& d, double* px, double* py) {
    *px = x0 + (d.x() + 1) * 0.5 * size;
    *py = y0 + (1 - d.z()) * 0.5 * size;
  };
  auto put = [&](int x, int y, float r, float g, float b) {
    if (x < x0 || y < y0 || x >= x0 + size || y >= y0 + size) return;
    canvas->at(x, y, 0) = r;
    canvas->at(x, y, 1) = g;
    canvas->at(x, y, 2) = b;
  };
  double tx, ty, fx, fy;
  to_px(truth, &tx, &ty);
  const double ring = std::max(4.0, size / 20.0);
  for (int k = 0; k < 720; ++k) {
    const double a = k * M_PI / 360;
    for (double w = -0.7; w <= 0.7; w += 0.7)
      put(int(tx + (ring + w) * std::cos(a)), int(ty + (ring + w) * std::sin(a)), 0, 1, 0);
  }
  to_px(found, &fx, &fy);
  if (found.y() < 0) {
    for (int k = -int(ring); k <= int(ring); ++k) {
      put(int(fx) + k, int(fy) + k, 1, 0, 0);
      put(int(fx) + k, int(fy) - k, 1, 0, 0);
    }
  }
}

}  // namespace
}  // namespace relight

int main(int argc, char** argv) {
  using namespace relight;
  CLI::App app("Recovered environment maps of a DiLiGenT run against the known directional lights", "diligent_lights");
  std::vector<std::string> inverse_dirs;
  std::string lights_path, json_path, figure_path;
  std::vector<std::string> figure_photos;
  int cell = 160;
  bool per_photo = false;
  app.add_option("INVERSE_DIR", inverse_dirs, "inverse stage outputs (lighting.json + envmaps/)")->required();
  app.add_option("--lights", lights_path, "lights.json of the ground truth (ingest's import/ground_truth/)")
      ->required();
  app.add_option("--json", json_path, "Also write the scores (and per-photo errors) as JSON to this file");
  app.add_flag("--per-photo", per_photo, "Print every photo's direction error and recovered power");
  app.add_option("--figure", figure_path, "Write a figure (PNG): a row per INVERSE_DIR, a column per photo");
  app.add_option("--photos", figure_photos, "Photos (file names) in the figure; default: four spread over the set")
      ->delimiter(',');
  app.add_option("--cell", cell, "Side of a figure cell [px]")->check(CLI::Range(32, 1024));
  CLI11_PARSE(app, argc, argv);
  try {
    const std::vector<KnownDirectionalLight> lights = ReadDirectionalLights(lights_path);
    std::map<std::string, const KnownDirectionalLight*> by_name;
    for (const auto& l : lights) by_name[l.photo] = &l;
    Json out = Json::array();
    for (const std::string& dir : inverse_dirs) {
      const LightEvaluation e = EvaluateDirectionalLights(dir, lights);
      if (e.photos.empty()) RELIGHT_USER_ERROR() << "no photo of '" << dir << "/lighting.json' is in " << lights_path;
      if (per_photo) {
        std::printf("%-10s %10s %12s %12s %12s %26s %26s\n", "photo", "error_deg", "power_r", "power_g", "power_b",
                    "direction_world", "true_direction_world");
        for (size_t k = 0; k < e.photos.size(); ++k) {
          const Eigen::Vector3d& d = e.direction_world[k];
          const Eigen::Vector3d& t = e.true_direction_world[k];
          std::printf("%-10s %10.3f %12.5g %12.5g %12.5g %8.4f %8.4f %8.4f %8.4f %8.4f %8.4f\n", e.photos[k].c_str(),
                      e.angle_error_deg[k], e.power_rgb[k].x(), e.power_rgb[k].y(), e.power_rgb[k].z(), d.x(), d.y(),
                      d.z(), t.x(), t.y(), t.z());
        }
      }
      std::printf(
          "%s\n  photos %zu, direction error median %.2f deg, p90 %.2f deg; intensity Pearson r/g/b "
          "%.3f %.3f %.3f, relative RMSE %.3f\n",
          dir.c_str(), e.photos.size(), e.median_angle_deg, e.p90_angle_deg, e.pearson.x(), e.pearson.y(),
          e.pearson.z(), e.relative_intensity_rmse);
      out.push_back({{"inverse", dir},
                     {"photos", e.photos.size()},
                     {"median_angle_deg", e.median_angle_deg},
                     {"p90_angle_deg", e.p90_angle_deg},
                     {"pearson_rgb", {e.pearson.x(), e.pearson.y(), e.pearson.z()}},
                     {"relative_intensity_rmse", e.relative_intensity_rmse},
                     {"angle_error_deg", e.angle_error_deg}});
    }
    if (!json_path.empty()) WriteJsonAtomic(json_path, out);

    if (!figure_path.empty()) {
      const Json first = ReadJsonFile(JoinPath(inverse_dirs[0], "lighting.json"));
      if (figure_photos.empty()) {
        const auto& photos = first.at("photos");
        for (int k = 0; k < 4; ++k) figure_photos.push_back(photos.at(k * (photos.size() - 1) / 3).at("name"));
      }
      const int gap = 4, cols = static_cast<int>(figure_photos.size()), rows = static_cast<int>(inverse_dirs.size());
      Image canvas(cols * cell + (cols + 1) * gap, rows * cell + (rows + 1) * gap, 3, 1.0f);
      for (int r = 0; r < rows; ++r) {
        const Json lighting = ReadJsonFile(JoinPath(inverse_dirs[r], "lighting.json"));
        std::map<std::string, std::string> maps;
        for (const auto& p : lighting.at("photos")) maps[p.at("name")] = p.at("envmap_oct");
        for (int c = 0; c < cols; ++c) {
          const std::string& name = figure_photos[c];
          if (!maps.count(name) || !by_name.count(name)) {
            RELIGHT_USER_ERROR() << "photo '" << name << "' is not in both '" << inverse_dirs[r]
                                 << "/lighting.json' and " << lights_path;
          }
          const Image oct = ReadImage(JoinPath(inverse_dirs[r], maps[name]));
          DrawCell(oct, by_name[name]->direction_world, BrightestLobeDirection(oct), cell, gap + c * (cell + gap),
                   gap + r * (cell + gap), &canvas);
        }
      }
      WriteImage(figure_path, canvas);
      std::printf("figure: %s (%d x %d cells: rows %s..., columns", figure_path.c_str(), rows, cols,
                  inverse_dirs[0].c_str());
      for (const auto& p : figure_photos) std::printf(" %s", p.c_str());
      std::printf(")\n");
    }
  } catch (const UserError& e) {
    std::fprintf(stderr, "diligent_lights: error: %s\n", e.what());
    return 2;
  }
  return 0;
}
