#include "geometry/align.h"

#include <gtest/gtest.h>

#include <random>

namespace relight {
namespace {

TEST(AlignTest, RecoversSimilarityExactlyAndRobustly) {
  std::mt19937 rng(1);
  std::normal_distribution<double> n(0, 1);
  Sim3 truth;
  truth.scale = 3.0;
  truth.rotation = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -1, 0.2).normalized()).toRotationMatrix();
  truth.translation = {5, -1, 2};
  std::vector<Eigen::Vector3d> src, dst;
  for (int i = 0; i < 30; ++i) {
    src.emplace_back(n(rng), n(rng), n(rng));
    dst.push_back(truth.Apply(src.back()));
  }
  const Sim3 est = EstimateSimilarity(src, dst);
  EXPECT_NEAR(est.scale, 3.0, 1e-10);
  EXPECT_TRUE(est.rotation.isApprox(truth.rotation, 1e-10));
  EXPECT_TRUE(est.translation.isApprox(truth.translation, 1e-10));
  // Three gross outliers do not move the robust estimate.
  for (int i = 0; i < 3; ++i) dst[i] += Eigen::Vector3d(10, 10, 10);
  const Sim3 robust = EstimateSimilarityRobust(src, dst);
  EXPECT_NEAR(robust.scale, 3.0, 1e-9);
  EXPECT_TRUE(robust.rotation.isApprox(truth.rotation, 1e-9));
}

TEST(AlignTest, CameraErrorsOfASimilarityCopyAreZero) {
  Reconstruction truth;
  truth.cameras[1] = Camera::Pinhole(1, 100, 100, 100, 100, 50, 50);
  for (uint32_t i = 1; i <= 8; ++i) {
    ImageRecord im;
    im.image_id = i;
    im.camera_id = 1;
    im.name = "p" + std::to_string(i);
    const double a = i * 0.7;
    im.SetPose(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
               Eigen::Vector3d(3 * std::cos(a), 3 * std::sin(a), 0.5 * i));
    truth.images[i] = im;
  }
  Reconstruction estimate = truth;
  Sim3 t;
  t.scale = 0.2;
  t.rotation = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()).toRotationMatrix();
  t.translation = {1, 2, 3};
  estimate.Transform(t);
  estimate.images.erase(8);
  const CameraErrors e = CompareCameras(estimate, truth);
  EXPECT_EQ(e.matched, 7);
  EXPECT_EQ(e.missing, 1);
  EXPECT_LT(e.median_rotation_deg, 1e-6);
  EXPECT_LT(e.median_center_error_relative, 1e-9);
  // A 2° perturbation of one camera shows up as its rotation error.
  ImageRecord& im = estimate.images[3];
  im.SetPose(Eigen::AngleAxisd(2.0 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix() * im.CamFromWorldRotation(),
             im.ProjectionCenter());
  const CameraErrors e2 = CompareCameras(estimate, truth);
  EXPECT_NEAR(e2.max_rotation_deg, 2.0, 1e-6);
}

}  // namespace
}  // namespace relight
