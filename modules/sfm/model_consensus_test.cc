// Model agreement and the two-view check on a synthetic ring of cameras whose
// projections are exact, so every expected count is known in closed form.
#include "sfm/model_consensus.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

namespace relight {
namespace {

// 8 cameras on a circle of radius 4 around the origin, 1 unit up, looking at the origin; f = 500 px.
Reconstruction Ring() {
  Reconstruction model;
  for (int i = 0; i < 8; ++i) {
    const uint32_t id = i + 1;
    model.cameras[id] = Camera::Pinhole(id, 640, 480, 500, 500, 320, 240);
    const double a = 2 * M_PI * i / 8;
    const Eigen::Vector3d center(4 * std::cos(a), 4 * std::sin(a), 1.0);
    const Eigen::Vector3d z = (-center).normalized();
    const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d y = z.cross(x);
    Eigen::Matrix3d r;
    r.row(0) = x;
    r.row(1) = y;
    r.row(2) = z;
    ImageRecord im;
    im.image_id = id;
    im.camera_id = id;
    im.name = "photo_" + std::to_string(i) + ".jpg";
    im.SetPose(r, center);
    model.images[id] = im;
  }
  return model;
}

// Exact projections of 100 points in a ball of radius 1 into each pair of neighbours (and next neighbours).
std::vector<PairObservations> Observe(const Reconstruction& model) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Eigen::Vector3d> points;
  while (points.size() < 100) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    if (p.norm() <= 1) points.push_back(p);
  }
  std::vector<PairObservations> pairs;
  for (int i = 0; i < 8; ++i) {
    for (int step : {1, 2}) {
      const ImageRecord& a = model.images.at(i + 1);
      const ImageRecord& b = model.images.at((i + step) % 8 + 1);
      PairObservations o;
      o.name1 = a.name;
      o.name2 = b.name;
      for (const auto& p : points) {
        Eigen::Vector2d pa, pb;
        if (model.Project(a, p, &pa) && model.Project(b, p, &pb)) {
          o.points1.push_back(pa);
          o.points2.push_back(pb);
        }
      }
      pairs.push_back(o);
    }
  }
  return pairs;
}

// Turns a camera about its own x axis (a tilt: image points move vertically, across the ring's nearly
// horizontal epipolar lines; a pan would move them along the lines, which no pair can see).
void Turn(Reconstruction* model, uint32_t id, double degrees) {
  ImageRecord& im = model->images.at(id);
  const Eigen::Vector3d c = im.ProjectionCenter();
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(degrees * M_PI / 180, Eigen::Vector3d::UnitX()).toRotationMatrix() * im.CamFromWorldRotation();
  im.SetPose(r, c);
}

Reconstruction Moved(const Reconstruction& model) {
  Reconstruction m = model;
  Sim3 s;
  s.scale = 2.5;
  s.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  s.translation = Eigen::Vector3d(3, -1, 2);
  m.Transform(s);
  return m;
}

TEST(CompareModels, TheSameCamerasInAnotherFrameAgreeExactly) {
  const Reconstruction a = Ring();
  const ModelAgreement g = CompareModels(a, Moved(a), 2.0);
  EXPECT_EQ(g.shared, 8);
  EXPECT_EQ(g.within_tolerance, 8);
  EXPECT_LT(g.median_rotation_deg, 1e-6);
  EXPECT_TRUE(g.agree());
}

TEST(CompareModels, OneMisplacedPhotoIsNamedAndThreeBreakTheAgreement) {
  const Reconstruction a = Ring();
  Reconstruction b = Moved(a);
  Turn(&b, 4, 10);
  ModelAgreement g = CompareModels(a, b, 2.0);
  EXPECT_EQ(g.within_tolerance, 7);
  ASSERT_EQ(g.differing.size(), 1u);
  EXPECT_EQ(g.differing[0], "photo_3.jpg");
  EXPECT_TRUE(g.agree());  // 7 of 8 >= 80 %
  Turn(&b, 1, -8);
  Turn(&b, 7, 12);
  g = CompareModels(a, b, 2.0);
  EXPECT_EQ(g.within_tolerance, 5);
  EXPECT_FALSE(g.agree());  // 5 of 8 < 80 %
}

TEST(TwoViewAgreement, ExactModelExplainsEveryPairAndATurnedPhotoNone) {
  Reconstruction model = Ring();
  const std::vector<PairObservations> pairs = Observe(model);
  TwoViewAgreement t = CheckTwoViewAgreement(model, pairs, 4.0);
  EXPECT_EQ(t.pairs, 16);
  EXPECT_EQ(t.agreeing, 16);
  // Turning one camera by 3 degrees moves its epipolar lines by about 500 px * tan(3 deg) = 26 px: every
  // pair it is part of (4 of the 16) disagrees, the others are untouched.
  Turn(&model, 3, 3);
  t = CheckTwoViewAgreement(model, pairs, 4.0);
  EXPECT_EQ(t.agreeing, 12);
  EXPECT_EQ(t.per_photo.at("photo_2.jpg").first, 0);
  EXPECT_EQ(t.per_photo.at("photo_2.jpg").second, 4);
  EXPECT_EQ(t.per_photo.at("photo_6.jpg").first, 4);
}

TEST(ChooseConsensusRun, KeepsTheRunsThatAgreeAndAreConsistent) {
  const Reconstruction right = Ring();
  const std::vector<PairObservations> pairs = Observe(right);
  std::vector<MapperRun> runs(3);
  runs[0].model = right;
  Turn(&runs[0].model, 2, 15);  // a wrong run with as many photos: 3 misplaced
  Turn(&runs[0].model, 5, -20);
  Turn(&runs[0].model, 7, 9);
  runs[1].model = Moved(right);
  runs[2].model = right;
  runs[2].model.images.erase(8);  // right, with a photo fewer
  for (auto& r : runs) {
    r.num_registered = static_cast<int>(r.model.images.size());
    r.two_view = CheckTwoViewAgreement(r.model, pairs, 4.0);
  }
  EXPECT_LT(runs[0].two_view.fraction(), kMinTwoViewAgreement);
  EXPECT_EQ(ChooseConsensusRun(&runs, 2.0), 1);
  EXPECT_EQ(runs[1].agrees_with, std::vector<int>({2}));
  EXPECT_TRUE(runs[0].agrees_with.empty());
  // No model at all.
  std::vector<MapperRun> none(2);
  EXPECT_EQ(ChooseConsensusRun(&none, 2.0), -1);
}

// COLMAP's mapper can abandon a model begun from a first pair and register those photos again in the one
// it builds next: that is no split. Photos only the smaller models hold are.
TEST(SplitOffPhotosTest, CountsPhotosTheLargestModelLacks) {
  const Reconstruction largest = Ring();  // photo_0 .. photo_7
  EXPECT_TRUE(SplitOffPhotos({}).empty());
  EXPECT_TRUE(SplitOffPhotos({largest}).empty());
  Reconstruction abandoned;  // photo_2, photo_3 and photo_4 again, under other ids
  for (uint32_t id : {3u, 4u, 5u}) {
    ImageRecord im = largest.images.at(id);
    im.image_id = id + 100;
    abandoned.images[im.image_id] = im;
  }
  EXPECT_TRUE(SplitOffPhotos({largest, abandoned}).empty());
  Reconstruction apart = abandoned;  // two of them and three photos the largest lacks
  apart.images.erase(103);
  for (int k = 0; k < 3; ++k) {
    ImageRecord im = largest.images.at(1);
    im.image_id = 200 + k;
    im.name = "other_" + std::to_string(k) + ".jpg";
    apart.images[im.image_id] = im;
  }
  EXPECT_EQ(SplitOffPhotos({largest, apart}).size(), 3u);
  EXPECT_EQ(SplitOffPhotos({largest, apart, apart, abandoned}).size(), 3u);  // each photo counted once
}

}  // namespace
}  // namespace relight
