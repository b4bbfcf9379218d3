// DiLiGenT photometric-stereo data sets (Shi et al., CVPR 2016) as pipeline
// scenes: every photo one known directional light, one fixed camera, an
// object whose shape is known. For the "ball", the sphere is fitted to
// mask.png (centre = mask centroid, radius = sqrt(area / π)).
//
// Conventions (checked on the data: Lambertian correlation 0.83-0.95 with
// these axes, <= 0.5 with y flipped): DiLiGenT's camera frame has x right,
// y up, z towards the viewer; light directions point from the object to the
// light. The pipeline's world frame (+Z up, docs/FORMATS.md) is
// X_w = x_d, Y_w = -z_d, Z_w = y_d. DiLiGenT assumes orthographic projection;
// it is modelled by a pinhole camera far away (distance 100 sphere radii, the
// ball then spans 0.6° of view, so view directions differ by at most 0.3° from
// orthographic) whose focal length reproduces the ball's size in pixels.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace relight {

struct DiligentImportOptions {
  int sphere_subdivisions = 5;     // subdivision levels of the octahedral sphere fitted to the ball (5: 4098 vertices)
  double camera_distance = 100.0;  // in sphere radii
};

struct KnownDirectionalLight {
  std::string photo;                 // photo file name
  Eigen::Vector3d direction_world;   // unit, from the object towards the light
  Eigen::Vector3d intensity_rgb;     // as given by the data set (relative)
};

struct DiligentScene {
  Eigen::Vector2d center_px;  // ball centre, COLMAP pixel coordinates
  double radius_px = 0;
  std::vector<KnownDirectionalLight> lights;
};

// True when `folder` holds a DiLiGenT object (filenames.txt, light_directions.txt, mask.png).
bool IsDiligentFolder(const std::string& folder);

// Writes `<output>/images/` (the photos, hard links where possible) and
// `<output>/ground_truth/` (COLMAP text model, mesh.ply of the fitted ball,
// lights.json) for the DiLiGenT object in `folder`. Throws UserError naming
// the file when the folder is incomplete or inconsistent.
DiligentScene ImportDiligent(const std::string& folder, const std::string& output,
                             const DiligentImportOptions& options = {});

// Directions (world) from DiLiGenT camera coordinates, and back.
Eigen::Vector3d DiligentToWorld(const Eigen::Vector3d& d);

// lights.json of a ground-truth folder (name, direction_world, intensity_rgb).
std::vector<KnownDirectionalLight> ReadDirectionalLights(const std::string& path);

}  // namespace relight
