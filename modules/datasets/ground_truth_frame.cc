#include "datasets/ground_truth_frame.h"

#include <filesystem>

#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"

namespace relight {
namespace fs = std::filesystem;

Reconstruction GroundTruthFrame::CamerasToModel(Reconstruction truth_cameras) const {
  if (!IsIdentity()) truth_cameras.Transform(truth_from_model.Inverse());
  return truth_cameras;
}

ImageRecord GroundTruthFrame::PoseToTruth(const ImageRecord& pose) const {
  if (IsIdentity()) return pose;
  ImageRecord out = pose;
  out.SetPose(pose.CamFromWorldRotation() * rotation().transpose(), truth_from_model.Apply(pose.ProjectionCenter()));
  return out;
}

TriangleMesh GroundTruthFrame::MeshToTruth(TriangleMesh mesh) const {
  if (IsIdentity()) return mesh;
  const Eigen::Matrix3f r = rotation().cast<float>();
  for (auto& v : mesh.vertices) v = truth_from_model.Apply(v.cast<double>()).cast<float>();
  for (auto& n : mesh.normals) n = (r * n).normalized();
  return mesh;
}

GroundTruthFrame RelateToGroundTruth(const std::string& sfm_dir, const GroundTruth& truth) {
  GroundTruthFrame frame;
  if (!truth.HasCameras()) {
    frame.reason = "no ground-truth cameras (" +
                   (truth.dir().empty() ? std::string("no ground-truth folder") : truth.CamerasFile() + " is missing") +
                   ")";
    return frame;
  }
  if (sfm_dir.empty() || !fs::is_directory(JoinPath(sfm_dir, "sparse"))) {
    frame.reason = "no sfm output (sparse/) to relate to the ground truth";
    return frame;
  }
  std::string mode;
  const std::string summary = JoinPath(sfm_dir, "sfm_summary.json");
  if (fs::is_regular_file(summary)) mode = ReadJsonFile(summary).value("mode", "");
  if (mode == "ground_truth") {
    frame.available = true;
    frame.method = "identity";
    return frame;
  }
  const Reconstruction estimate = Reconstruction::Read(JoinPath(sfm_dir, "sparse"));
  CameraErrors errors = CompareCameras(estimate, truth.ReadCameras());
  if (errors.matched < 3) {
    frame.reason = "only " + std::to_string(errors.matched) +
                   " photo(s) are both registered and in the ground truth; at least 3 are needed to align";
    return frame;
  }
  frame.available = true;
  frame.method = "similarity";
  frame.truth_from_model = errors.truth_from_estimate;
  frame.has_camera_errors = true;
  frame.camera_errors = std::move(errors);
  RLOG_INFO(
      "model frame -> ground truth: similarity from {} camera centres (scale {:.4g}), median rotation error "
      "{:.3f} deg",
      frame.camera_errors.matched, frame.truth_from_model.scale, frame.camera_errors.median_rotation_deg);
  return frame;
}

}  // namespace relight
