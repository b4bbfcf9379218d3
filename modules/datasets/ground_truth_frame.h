// How the recovered model's world frame (the sfm stage's) relates to the
// ground truth's: identity when the sfm stage used the ground-truth cameras,
// else the robust similarity that maps the estimated camera centres onto the
// true ones (geometry/align.h, CompareCameras). Everything compared with the
// ground truth goes through it: held-out cameras and environment maps are
// brought into the model's frame to relight the model (the relight stage's
// main does that); the model's mesh, albedo and environment maps are brought
// into the truth's frame to be scored (evaluate).
#pragma once

#include <Eigen/Core>
#include <string>

#include "datasets/ground_truth.h"
#include "geometry/align.h"
#include "geometry/mesh.h"
#include "geometry/reconstruction.h"
#include "sphere/envmap.h"

namespace relight {

struct GroundTruthFrame {
  bool available = false;          // ground-truth cameras exist and the frames could be related
  std::string method;              // "identity" (sfm.mode ground_truth) or "similarity" (camera centres)
  std::string reason;              // why it is not available
  Sim3 truth_from_model;           // x_truth = s R x_model + t
  bool has_camera_errors = false;  // true for "similarity": the sfm stage estimated the cameras
  CameraErrors camera_errors;      // estimated against true cameras (similarity only)

  // Rotation part R (directions: d_truth = R d_model).
  const Eigen::Matrix3d& rotation() const { return truth_from_model.rotation; }
  // A ground-truth environment map as seen in the model's frame: L_model(d) = L_truth(R d).
  EnvMap EnvToModel(const EnvMap& truth_env) const { return truth_env.Transformed(rotation().transpose(), 1.0); }
  // A model-frame environment map in the truth's frame: L_truth(d) = L_model(R^T d).
  EnvMap EnvToTruth(const EnvMap& model_env) const { return model_env.Transformed(rotation(), 1.0); }
  // Ground-truth cameras (e.g. held-out views) moved into the model's frame (same images).
  Reconstruction CamerasToModel(Reconstruction truth_cameras) const;
  // A model-frame camera pose in the truth's frame.
  ImageRecord PoseToTruth(const ImageRecord& model_pose) const;
  // A model-frame mesh (positions and normals) in the truth's frame.
  TriangleMesh MeshToTruth(TriangleMesh mesh) const;
  // Whether truth_from_model is exactly the identity.
  bool IsIdentity() const { return method == "identity"; }
};

// Relates the frames from the sfm stage's output (`sfm_dir`: sparse/, sfm_summary.json) and the
// ground truth's cameras. Not available (with a reason) when either is missing or fewer than 3 photos match
// by name; throws UserError only for unreadable files.
GroundTruthFrame RelateToGroundTruth(const std::string& sfm_dir, const GroundTruth& truth);

}  // namespace relight
