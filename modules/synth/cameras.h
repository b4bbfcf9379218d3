// Cameras of a synthetic collection: views around the object at varying
// elevation, distance, focal length, image size and orientation, aimed at the
// object, upright (+Z up in the image, i.e. image -y) up to a small roll.
// The 35 mm-equivalent focal length is exact (f_px = f35 * diagonal_px / 43.27 mm),
// so EXIF carries the same prior a real camera would.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "geometry/camera.h"
#include "geometry/reconstruction.h"
#include "render/rng.h"
#include "synth/synthesize_options.h"

namespace relight {

// One camera of the collection or of the held-out views.
struct SyntheticView {
  std::string name;          // image name ("photo_000.jpg", "view_0")
  Camera camera;             // COLMAP intrinsics
  ImageRecord pose;          // cam_from_world, image_id = camera_id
  int focal_35mm = 0;        // 35 mm-equivalent focal length [mm]
  double azimuth_deg = 0;    // of the camera centre around the object's axis, from +X towards +Y
  double elevation_deg = 0;  // above the object's centre
  double distance = 0;       // from the aim point [scene units]
  double roll_deg = 0;       // about the optical axis
};

// Rotation cam_from_world of a camera at `center` looking at `target` with +Z
// up in the image (image y down), rolled by `roll_deg` about the optical axis.
Eigen::Matrix3d LookAtRotation(const Eigen::Vector3d& center, const Eigen::Vector3d& target, double roll_deg);

// Focal length in pixels of a 35 mm-equivalent focal length for an image of the given size.
double FocalPixelsFrom35mm(double focal_35mm, int width, int height);

// The photos' cameras around a bounding sphere (`center`, `radius`).
std::vector<SyntheticView> PlacePhotoCameras(const SynthesizeOptions& options, const Eigen::Vector3d& center,
                                             double radius, Pcg32* rng);
// Held-out views for relighting references: square PINHOLE images of
// `relight_image_size`, one per sector of the circle at the azimuth farthest
// from every photo's, middle elevation, `relight_focal_35mm`, the mean object fill.
std::vector<SyntheticView> PlaceHeldOutCameras(const SynthesizeOptions& options, const Eigen::Vector3d& center,
                                               double radius, const std::vector<double>& photo_azimuths_deg);

// A COLMAP model of the views (cameras and images, no points).
Reconstruction ViewsToReconstruction(const std::vector<SyntheticView>& views);

}  // namespace relight
