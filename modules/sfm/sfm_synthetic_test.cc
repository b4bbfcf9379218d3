// Issue 8's acceptance test on the synthetic generator's photo collection:
// build/bin/synthesize renders photos with known cameras (varying focal
// lengths and sizes, EXIF focal lengths), ingest and sfm run on them, and the
// recovered cameras are compared with the ground truth after a similarity
// alignment: all photos registered, median rotation error ≤ 0.5°, median
// centre error ≤ 1% of the scene radius.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/json.h"
#include "geometry/align.h"
#include "ingest/ingest.h"
#include "sfm/sfm.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

TEST(SfmSynthetic, AllPhotosRegisterWithAccurateCameras) {
  testing::TempDir dir;
  // The CI scene, configs/synthetic_tiny.yaml (its synthesize section): 20
  // photos on a ring 22-30 deg up, focal 40-50 mm, a mosaic ground, and five
  // lighting conditions each shared by four neighbouring views. With a
  // different sun in every photo the moving shadows defeat SIFT matching (an
  // earlier version of this test, one lighting per photo, put 1 of 20 views
  // 127 deg off in one of three runs). Measured with this scene: 20/20,
  // median rotation error 0.10-0.14 deg, centre 0.35-0.45%, +Z within 0.3 deg
  // (docs/RESULTS.md).
  const std::string config = testing::SourceDir() + "/configs/synthetic_tiny.yaml";
  std::string log;
  const int status = testing::RunCommand(
      testing::BinDir() + "/synthesize --config " + config + " --output " + (dir / "synth"), &log);
  ASSERT_EQ(status, 0) << log;

  // ingest and sfm run as the stage executables, as the pipeline runs them.
  const std::string ingest_command = testing::BinDir() + "/ingest --set ingest.images=" + (dir / "synth/images") +
                                     " --set ingest.ground_truth=" + (dir / "synth/ground_truth") + " --output " +
                                     (dir / "ingest");
  ASSERT_EQ(testing::RunCommand(ingest_command, &log), 0) << log;
  ASSERT_EQ(ReadIngestManifest(dir / "ingest").photos.size(), 20u) << "ingest dropped synthetic photos";
  const std::string sfm_command =
      testing::BinDir() + "/sfm --input ingest=" + (dir / "ingest") + " --output " + (dir / "sfm");
  ASSERT_EQ(testing::RunCommand(sfm_command, &log), 0) << log;
  const Json summary = ReadJsonFile(dir / "sfm/sfm_summary.json");
  const int num_photos = summary.at("num_photos").get<int>();
  const int num_registered = summary.at("num_registered").get<int>();
  EXPECT_EQ(num_photos, 20);
  EXPECT_EQ(num_registered, num_photos) << summary.at("unregistered").dump();

  const Reconstruction model = Reconstruction::Read(dir / "sfm/sparse");
  const Reconstruction truth = Reconstruction::Read(dir / "ingest/ground_truth");
  const CameraErrors e = CompareCameras(model, truth);
  EXPECT_EQ(e.matched, 20);
  EXPECT_LE(e.median_rotation_deg, 0.5);
  EXPECT_LE(e.median_center_error_relative, 0.01);
  // COLMAP can place a view at the far end of the ring with the planar
  // ambiguity of the ground (measured: 2 of 20 off by > 100 deg); the median
  // hides them, so bound their number too.
  const int accurate =
      static_cast<int>(std::count_if(e.rotation_deg.begin(), e.rotation_deg.end(), [](double d) { return d < 1.0; }));
  EXPECT_GE(accurate, 16) << "photos with rotation error below 1 deg";
  std::printf(
      "synthetic: %d/%d registered, median rotation error %.3f deg (max %.3f), median centre error "
      "%.3f%% of the scene radius\n",
      num_registered, num_photos, e.median_rotation_deg, e.max_rotation_deg, 100 * e.median_center_error_relative);

  // The world frame is +Z up, like the synthetic scene: after the similarity
  // alignment the rotation to the true frame is small (the mean camera up of
  // cameras looking slightly down leans back by a few degrees at most).
  const double up_angle_deg =
      std::acos(std::clamp((e.truth_from_estimate.rotation * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0)) * 180 / M_PI;
  std::printf("synthetic: the estimated +Z is %.2f deg from the true +Z\n", up_angle_deg);
  EXPECT_LT(up_angle_deg, 2.0);  // measured 0.33 deg
}

}  // namespace
}  // namespace relight
