// RenderView against closed forms: a white-furnace sphere (object pixels = rho E
// by a z-test over pixels, background exactly E), depth and mask of a plane and
// a sphere (pixel convention of COLMAP, with and without distortion), a hard
// shadow under a directional light (exactly black inside, exact Lambertian value
// outside), and determinism across thread counts.
#include "render/render_view.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>

#include "render/test_scenes.h"

namespace relight {
namespace {

using render_testing::Icosphere;
using render_testing::Plane;

ImageRecord LookAt(const Eigen::Vector3d& center, const Eigen::Vector3d& target) {
  const Eigen::Vector3d forward = (target - center).normalized();
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d r;
  r.row(0) = right;
  r.row(1) = down;
  r.row(2) = forward;
  ImageRecord image;
  image.SetPose(r, center);
  return image;
}

TEST(RenderViewTest, WhiteFurnaceSphere) {
  const Eigen::Vector3d albedo(0.7, 0.5, 0.3);
  const double radiance = 1.5;
  Scene scene({{Icosphere(1.0, Eigen::Vector3d::Zero(), 4), LambertianModel(albedo)}});
  const Lighting lighting = Lighting::FromEnvMap(EnvMap::FromLatLong(Image(16, 8, 3, float(radiance))));
  const Camera camera = Camera::Pinhole(1, 64, 48, 60, 60, 32, 24);
  const ImageRecord pose = LookAt({0, -4, 0.5}, Eigen::Vector3d::Zero());
  const RenderedView view = RenderView(scene, lighting, camera, pose, RenderOptions());
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  int n = 0, background = 0;
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      const Eigen::Vector3d v(view.radiance.at(x, y, 0), view.radiance.at(x, y, 1), view.radiance.at(x, y, 2));
      if (view.coverage.at(x, y) == 1.0f) {
        EXPECT_EQ(view.mask.at(x, y), 1.0f);
        sum += v;
        sum2 += v.cwiseProduct(v);
        ++n;
      } else if (view.coverage.at(x, y) == 0.0f) {
        ++background;
        EXPECT_EQ(view.surface.at(x, y), -1.0f);
        EXPECT_EQ(view.depth.at(x, y), 0.0f);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(v[c], radiance, 1e-5);
      }
    }
  ASSERT_GT(n, 200);
  ASSERT_GT(background, 200);
  const Eigen::Vector3d mean = sum / n;
  for (int c = 0; c < 3; ++c) {
    const double std_error = std::sqrt(std::max(0.0, sum2[c] / n - mean[c] * mean[c]) / (n - 1));
    EXPECT_NEAR(mean[c], albedo[c] * radiance, 4.5 * std_error + 1e-6) << "channel " << c;
  }
}

TEST(RenderViewTest, DepthOfFrontoParallelPlane) {
  // Camera at the origin looking along +z (identity pose); a plane at z = 5 fills the view.
  Scene scene({{Plane(100, 5.0, 4), LambertianModel(Eigen::Vector3d(0.5, 0.5, 0.5))}});
  Lighting lighting;
  lighting.directional.push_back({-Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Ones()});
  const Camera camera = Camera::Pinhole(1, 40, 30, 35, 35, 20, 15);
  const RenderedView view = RenderView(scene, lighting, camera, ImageRecord(), RenderOptions());
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      EXPECT_NEAR(view.depth.at(x, y), 5.0f, 1e-4f);
      EXPECT_EQ(view.mask.at(x, y), 1.0f);
      // Lambertian 0.5 lit head-on by irradiance 1, seen from the back side (two-sided): 0.5/pi.
      EXPECT_NEAR(view.radiance.at(x, y, 0), 0.5 / M_PI, 1e-5);
    }
}

// Centroid of the mask in continuous pixel coordinates (pixel centres at +0.5).
Eigen::Vector2d MaskCentroid(const Image& mask) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double n = 0;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x)
      if (mask.at(x, y) > 0) {
        sum += Eigen::Vector2d(x + 0.5, y + 0.5);
        n += 1;
      }
  return sum / n;
}

TEST(RenderViewTest, SphereProjectsWhereColmapSays) {
  for (const bool distorted : {false, true}) {
    Camera camera = Camera::Pinhole(1, 64, 48, 100, 100, 32, 24);
    if (distorted) {
      camera.model = "SIMPLE_RADIAL";
      camera.params = {100, 32, 24, 0.08};
    }
    // A sphere whose centre projects (undistorted) to the centre of pixel (20, 13).
    const double z = 10, radius = 0.3;
    const Eigen::Vector3d centre((20.5 - 32) * z / 100, (13.5 - 24) * z / 100, z);
    Scene scene({{Icosphere(radius, centre, 4), LambertianModel(Eigen::Vector3d(0.5, 0.5, 0.5))}});
    Lighting lighting;
    ImageRecord pose;  // identity: world = camera frame
    pose.camera_id = 1;
    const RenderedView view = RenderView(scene, lighting, camera, pose, RenderOptions());
    Reconstruction model;
    model.cameras[1] = camera;
    Eigen::Vector2d projected;
    ASSERT_TRUE(model.Project(pose, centre, &projected));
    const Eigen::Vector2d centroid = MaskCentroid(view.mask);
    EXPECT_NEAR(centroid.x(), projected.x(), 0.1) << "distorted " << distorted;
    EXPECT_NEAR(centroid.y(), projected.y(), 0.1) << "distorted " << distorted;
    if (!distorted) {
      // The pixel-centre ray of pixel (20, 13) passes through the sphere's centre: depth of the front point.
      const double expected = (centre.norm() - radius) * centre.z() / centre.norm();
      EXPECT_NEAR(view.depth.at(20, 13), expected, 1e-3);
      // Mask = pixel centres inside the projected disc (radius f r / sqrt(d^2 - r^2) at this distance).
      const double disc = 100 * radius / std::sqrt(centre.squaredNorm() - radius * radius);
      for (int y = 0; y < camera.height; ++y)
        for (int x = 0; x < camera.width; ++x) {
          const double r = Eigen::Vector2d(x + 0.5 - projected.x(), y + 0.5 - projected.y()).norm();
          if (r < disc - 0.1) {
            EXPECT_EQ(view.mask.at(x, y), 1.0f) << x << "," << y;
          } else if (r > disc + 0.1) {
            EXPECT_EQ(view.mask.at(x, y), 0.0f) << x << "," << y;
          }
        }
    }
  }
}

TEST(RenderViewTest, HardShadowIsBlackAndLitGroundIsExact) {
  // Ground z = 0 (occluder role), a floating square blocker over [-0.5, 0.5]^2 at z = 1, sun straight down.
  const double rho = 0.6, irradiance = 3.0;
  TriangleMesh blocker = Plane(0.5, 1.0, 1);
  Scene scene({{Plane(4, 0, 40), LambertianModel(Eigen::Vector3d::Constant(rho)), SurfaceRole::kOccluder},
               {blocker, LambertianModel(Eigen::Vector3d::Constant(0.2))}});
  Lighting lighting;
  lighting.directional.push_back({Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Constant(irradiance)});
  const Camera camera = Camera::Pinhole(1, 80, 60, 70, 70, 40, 30);
  const ImageRecord pose = LookAt({0.3, -4, 5}, Eigen::Vector3d::Zero());
  const RenderedView view = RenderView(scene, lighting, camera, pose, RenderOptions());
  const Eigen::Matrix3d world_from_cam = pose.CamFromWorldRotation().transpose();
  int shadowed = 0, lit = 0;
  for (int y = 1; y + 1 < camera.height; ++y)
    for (int x = 1; x + 1 < camera.width; ++x) {
      bool ground_only = true;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) ground_only &= view.surface.at(x + dx, y + dy) == 0.0f;
      if (!ground_only) continue;
      const Eigen::Vector3d ray = world_from_cam * camera.RayFromImage({x + 0.5, y + 0.5});
      const Eigen::Vector3d p = pose.ProjectionCenter() + ray * (-pose.ProjectionCenter().z() / ray.z());
      const double inside = std::max(std::abs(p.x()), std::abs(p.y()));
      if (inside < 0.5 - 0.12) {
        ++shadowed;
        EXPECT_EQ(view.radiance.at(x, y, 0), 0.0f) << x << "," << y;
      } else if (inside > 0.5 + 0.12) {
        ++lit;
        EXPECT_NEAR(view.radiance.at(x, y, 0), rho / M_PI * irradiance, 1e-5) << x << "," << y;
      }
    }
  EXPECT_GT(shadowed, 20);
  EXPECT_GT(lit, 500);
}

TEST(RenderViewTest, DeterministicAcrossThreadCounts) {
  Scene scene({{Icosphere(1.0, Eigen::Vector3d::Zero(), 3), LambertianModel(Eigen::Vector3d(0.7, 0.5, 0.3))},
               {Plane(3, -1, 8), LambertianModel(Eigen::Vector3d(0.4, 0.4, 0.4)), SurfaceRole::kOccluder}});
  Image sky(32, 16, 3, 0.2f);
  for (int x = 0; x < 32; ++x) sky.at(x, 2, 0) = 40.0f;
  const Lighting lighting = Lighting::FromEnvMap(EnvMap::FromLatLong(sky));
  const Camera camera = Camera::Pinhole(1, 48, 40, 40, 40, 24, 20);
  const ImageRecord pose = LookAt({1, -4, 1.5}, Eigen::Vector3d::Zero());
  RenderOptions options;
  options.interreflection = true;
  options.tile_size = 7;
  RenderedView one;
  {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    one = RenderView(scene, lighting, camera, pose, options);
  }
  const RenderedView many = RenderView(scene, lighting, camera, pose, options);
  EXPECT_EQ(one.radiance.pixels, many.radiance.pixels);
  options.seed = 2;
  const RenderedView other = RenderView(scene, lighting, camera, pose, options);
  EXPECT_NE(one.radiance.pixels, other.radiance.pixels);
  EXPECT_EQ(one.depth.pixels, other.depth.pixels);
}

}  // namespace
}  // namespace relight
