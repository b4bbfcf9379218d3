#include "synth/cameras.h"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>

#include "core/error.h"

namespace relight {
namespace {

constexpr double kDiagonal35mm = 43.266615305567875;  // hypot(36, 24)

// Camera at `elevation`/`azimuth` around `target`, at the distance where the
// bounding sphere spans `fill` of the shorter image side.
SyntheticView Place(const Eigen::Vector3d& target, double radius, double azimuth_deg, double elevation_deg, double fill,
                    double roll_deg, const Camera& camera) {
  SyntheticView view;
  view.camera = camera;
  const double shorter = std::min(camera.width, camera.height);
  const double tan_half = fill * shorter / (2.0 * camera.FocalX());
  const double distance = radius / std::sin(std::atan(tan_half));
  const double az = azimuth_deg * M_PI / 180, el = elevation_deg * M_PI / 180;
  const Eigen::Vector3d center =
      target + distance * Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  view.pose.SetPose(LookAtRotation(center, target, roll_deg), center);
  view.azimuth_deg = std::fmod(azimuth_deg + 720.0, 360.0);
  view.elevation_deg = elevation_deg;
  view.distance = distance;
  view.roll_deg = roll_deg;
  return view;
}

}  // namespace

Eigen::Matrix3d LookAtRotation(const Eigen::Vector3d& center, const Eigen::Vector3d& target, double roll_deg) {
  const Eigen::Vector3d forward = (target - center).normalized();
  Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ());
  RELIGHT_CHECK_GT(right.norm(), 1e-9) << "camera looks straight up or down";
  right.normalize();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d r;
  r.row(0) = right;
  r.row(1) = down;
  r.row(2) = forward;
  return Eigen::AngleAxisd(roll_deg * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix() * r;
}

double FocalPixelsFrom35mm(double focal_35mm, int width, int height) {
  return focal_35mm * std::hypot(double(width), double(height)) / kDiagonal35mm;
}

std::vector<SyntheticView> PlacePhotoCameras(const SynthesizeOptions& o, const Eigen::Vector3d& center, double radius,
                                             Pcg32* rng) {
  std::vector<SyntheticView> views;
  const double azimuth0 = rng->Uniform(0, 360);
  const double golden = 0.6180339887498949, elevation_phase = rng->Uniform();
  for (int i = 0; i < o.num_photos; ++i) {
    // Image size and orientation.
    const int longer = o.image_size_min + int(rng->UniformInt(uint32_t(o.image_size_max - o.image_size_min + 1)));
    const double aspect = o.aspect_ratios[i % o.aspect_ratios.size()];
    const int shorter = std::max(8, int(std::lround(longer / aspect)));
    const bool portrait = rng->Uniform() < o.portrait_fraction;
    const int width = portrait ? shorter : longer, height = portrait ? longer : shorter;
    const int f35 = o.focal_35mm_min + int(rng->UniformInt(uint32_t(o.focal_35mm_max - o.focal_35mm_min + 1)));
    const double f = FocalPixelsFrom35mm(f35, width, height);
    Camera camera;
    camera.camera_id = uint32_t(i + 1);
    camera.model = o.camera_model;
    camera.width = width;
    camera.height = height;
    if (o.camera_model == "SIMPLE_PINHOLE") {
      camera.params = {f, width / 2.0, height / 2.0};
    } else if (o.camera_model == "PINHOLE") {
      camera.params = {f, f, width / 2.0, height / 2.0};
    } else {
      camera.params = {f, width / 2.0, height / 2.0, rng->Uniform(-1, 1) * o.radial_distortion_max};
    }
    // Placement: evenly spaced azimuths with jitter, elevations spread by a golden-ratio sequence.
    const double azimuth = azimuth0 + 360.0 * i / o.num_photos + rng->Uniform(-1, 1) * o.azimuth_jitter_deg;
    const double t = std::fmod(elevation_phase + golden * i, 1.0);
    const double elevation = o.elevation_min_deg + t * (o.elevation_max_deg - o.elevation_min_deg);
    const double fill = rng->Uniform(o.object_fill_min, o.object_fill_max);
    const double roll = rng->Uniform(-1, 1) * o.roll_deg_max;
    const Eigen::Vector3d aim =
        center +
        o.aim_jitter * o.object_size * Eigen::Vector3d(rng->Uniform(-1, 1), rng->Uniform(-1, 1), rng->Uniform(-1, 1));
    SyntheticView view = Place(aim, radius, azimuth, elevation, fill, roll, camera);
    char name[32];
    std::snprintf(name, sizeof(name), "photo_%03d.jpg", i);
    view.name = name;
    view.focal_35mm = f35;
    view.pose.image_id = uint32_t(i + 1);
    view.pose.camera_id = camera.camera_id;
    view.pose.name = view.name;
    views.push_back(std::move(view));
  }
  return views;
}

std::vector<SyntheticView> PlaceHeldOutCameras(const SynthesizeOptions& o, const Eigen::Vector3d& center, double radius,
                                               const std::vector<double>& photo_azimuths_deg) {
  std::vector<SyntheticView> views;
  const int n = o.relight_views;
  const int size = o.relight_image_size;
  const double f = FocalPixelsFrom35mm(o.relight_focal_35mm, size, size);
  for (int k = 0; k < n; ++k) {
    const Camera camera = Camera::Pinhole(uint32_t(k + 1), size, size, f, f, size / 2.0, size / 2.0);
    // In sector k of the circle, the azimuth farthest from every photo's (searched in 0.5-degree steps).
    double azimuth = 360.0 * (k + 0.5) / n, best = -1;
    for (double a = 360.0 * k / n; a < 360.0 * (k + 1) / n; a += 0.5) {
      double nearest = 360;
      for (double p : photo_azimuths_deg) {
        const double d = std::fmod(std::abs(a - p) + 720.0, 360.0);
        nearest = std::min(nearest, std::min(d, 360.0 - d));
      }
      if (nearest > best) {
        best = nearest;
        azimuth = a;
      }
    }
    const double elevation = 0.5 * (o.elevation_min_deg + o.elevation_max_deg);
    const double fill = 0.5 * (o.object_fill_min + o.object_fill_max);
    SyntheticView view = Place(center, radius, azimuth, elevation, fill, 0.0, camera);
    view.name = "view_" + std::to_string(k);
    view.focal_35mm = o.relight_focal_35mm;
    view.pose.image_id = uint32_t(k + 1);
    view.pose.camera_id = camera.camera_id;
    view.pose.name = view.name;
    views.push_back(std::move(view));
  }
  return views;
}

Reconstruction ViewsToReconstruction(const std::vector<SyntheticView>& views) {
  Reconstruction model;
  for (const SyntheticView& v : views) {
    model.cameras[v.camera.camera_id] = v.camera;
    model.images[v.pose.image_id] = v.pose;
  }
  return model;
}

}  // namespace relight
