// compare_cameras: camera errors of a COLMAP model against ground truth after
// a robust similarity alignment of the camera centres (geometry/align.h).
//
//   compare_cameras ESTIMATE_MODEL TRUTH [--json OUT.json]
//
// ESTIMATE_MODEL is a COLMAP model folder (.bin or .txt, e.g. <sfm>/sparse);
// TRUTH is a COLMAP model folder or a Middlebury camera file (`*_par.txt`:
// per line name, K (9), R (9), t (3), P = K[R t]). Images are matched by name.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "core/error.h"
#include "core/json.h"
#include "geometry/align.h"
#include "geometry/reconstruction.h"
#include "sfm/sfm.h"

int main(int argc, char** argv) {
  using namespace relight;
  CLI::App app("Camera rotation and centre errors of a COLMAP model against ground truth", "compare_cameras");
  std::string estimate_dir, truth_path, json_path;
  app.add_option("ESTIMATE_MODEL", estimate_dir, "COLMAP model folder (cameras/images .bin or .txt)")->required();
  app.add_option("TRUTH", truth_path, "COLMAP model folder, or a Middlebury *_par.txt camera file")->required();
  app.add_option("--json", json_path, "Also write the errors as JSON to this file");
  CLI11_PARSE(app, argc, argv);
  try {
    const Reconstruction estimate = Reconstruction::Read(estimate_dir);
    Reconstruction truth;
    if (std::filesystem::is_directory(truth_path)) {
      truth = Reconstruction::Read(truth_path);
    } else {
      // Image size only matters for the intrinsics, not for the pose errors.
      const Camera& any = estimate.cameras.empty() ? Camera() : estimate.cameras.begin()->second;
      truth = ReadMiddleburyCameras(truth_path, std::max(1, any.width), std::max(1, any.height));
    }
    const CameraErrors e = CompareCameras(estimate, truth);
    if (e.matched < 3) {
      RELIGHT_USER_ERROR() << "only " << e.matched << " image names of " << estimate_dir << " appear in " << truth_path
                           << "; need at least 3 to align the two";
    }
    std::printf("%-28s %12s %14s\n", "image", "rotation_deg", "center_error");
    for (int i = 0; i < e.matched; ++i) {
      std::printf("%-28s %12.4f %14.6g\n", e.names[i].c_str(), e.rotation_deg[i], e.center_error[i]);
    }
    std::printf("matched %d, missing %d (of %zu in the truth)\n", e.matched, e.missing, truth.images.size());
    std::printf("rotation error: median %.4f deg, max %.4f deg\n", e.median_rotation_deg, e.max_rotation_deg);
    std::printf("centre error: median %.6g (%.4f%% of the scene radius %.6g), alignment scale %.6g\n",
                e.median_center_error, 100.0 * e.median_center_error_relative, e.scene_radius,
                e.truth_from_estimate.scale);
    if (!json_path.empty()) {
      OrderedJson j;
      j["estimate"] = estimate_dir;
      j["truth"] = truth_path;
      j["matched"] = e.matched;
      j["missing"] = e.missing;
      j["median_rotation_deg"] = e.median_rotation_deg;
      j["max_rotation_deg"] = e.max_rotation_deg;
      j["median_center_error"] = e.median_center_error;
      j["median_center_error_relative"] = e.median_center_error_relative;
      j["scene_radius"] = e.scene_radius;
      OrderedJson per_image = OrderedJson::array();
      for (int i = 0; i < e.matched; ++i) {
        per_image.push_back(
            {{"name", e.names[i]}, {"rotation_deg", e.rotation_deg[i]}, {"center_error", e.center_error[i]}});
      }
      j["images"] = per_image;
      WriteJsonAtomic(json_path, j);
    }
    return 0;
  } catch (const UserError& e) {
    std::cerr << "compare_cameras: error: " << e.what() << "\n";
    return 2;
  }
}
