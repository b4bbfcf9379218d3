// The sfm stage on a synthetic collection whose easiest first pair leads
// COLMAP to a wrong reconstruction: build/bin/synthesize renders photos with
// known cameras, ingest and sfm run on them twice, and the recovered cameras
// are compared with the ground truth after a similarity alignment (issue 33:
// at least 15 of 16 photos registered at a median rotation error ≤ 0.5°) and
// with each other (the same input gives the same cameras); then once more with
// the retrieval matcher and the hierarchical mapper.
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

TEST(SfmSynthetic, WrongFirstModelIsCaughtAndTheRunIsRepeatable) {
  testing::TempDir dir;
  // configs/synthetic_bunny.yaml's collection: 24 photos of 480-640 px around
  // the Stanford bunny, focal 28-85 mm, 12 lighting conditions with the two
  // photos that share one on opposite sides of the ring (neighbours never
  // share their light), real HDR maps and skies, a blocker, passers-by. Its
  // best-matched pair of photos (about 490 inliers) is one photo straight
  // behind another: COLMAP's own choice of first pair built a wrong model from
  // it (22 of 24 photos at a median rotation error of 18-31 deg, reprojection
  // error 0.9 px) that 21-29 % of the photo pairs contradict; the stage must
  // find the right one (measured 24 of 24 at 0.18 deg, 23 on another machine). No relighting
  // references: they take time and the stage does not read them.
  const std::string config = testing::SourceDir() + "/configs/synthetic_bunny.yaml";
  std::string log;
  const int status = testing::RunCommand(testing::BinDir() + "/synthesize --config " + config +
                                             " --set synthesize.relight_views=0 --output " + (dir / "synth"),
                                         &log);
  ASSERT_EQ(status, 0) << log;

  // ingest and sfm run as the stage executables, as the pipeline runs them.
  const std::string ingest_command = testing::BinDir() + "/ingest --set ingest.images=" + (dir / "synth/images") +
                                     " --set ingest.ground_truth=" + (dir / "synth/ground_truth") + " --output " +
                                     (dir / "ingest");
  ASSERT_EQ(testing::RunCommand(ingest_command, &log), 0) << log;
  ASSERT_EQ(ReadIngestManifest(dir / "ingest").photos.size(), 24u) << "ingest dropped synthetic photos";
  for (const char* run : {"sfm", "sfm_again"}) {
    const std::string sfm_command =
        testing::BinDir() + "/sfm --input ingest=" + (dir / "ingest") + " --output " + (dir / run);
    ASSERT_EQ(testing::RunCommand(sfm_command, &log), 0) << log;
  }
  const Json summary = ReadJsonFile(dir / "sfm/sfm_summary.json");
  const int num_photos = summary.at("num_photos").get<int>();
  const int num_registered = summary.at("num_registered").get<int>();
  EXPECT_EQ(num_photos, 24);
  EXPECT_GE(num_registered, 23) << summary.at("unregistered").dump();
  const std::string consensus = summary.at("consensus").get<std::string>();
  EXPECT_TRUE(consensus == "agreed" || consensus == "consistent") << consensus;

  const Reconstruction model = Reconstruction::Read(dir / "sfm/sparse");
  const Reconstruction truth = Reconstruction::Read(dir / "ingest/ground_truth");
  const CameraErrors e = CompareCameras(model, truth);
  EXPECT_EQ(e.matched, num_registered);
  EXPECT_LE(e.median_rotation_deg, 0.5);
  EXPECT_LE(e.median_center_error_relative, 0.01);
  // A photo placed on the wrong side of a planar ambiguity hides behind the median: bound them all.
  EXPECT_LE(e.max_rotation_deg, 2.0);
  std::printf(
      "synthetic: %d/%d registered (%s), median rotation error %.3f deg (max %.3f), median centre error "
      "%.3f%% of the scene radius\n",
      num_registered, num_photos, consensus.c_str(), e.median_rotation_deg, e.max_rotation_deg,
      100 * e.median_center_error_relative);

  // The world frame is +Z up, like the synthetic scene (the mean camera up of cameras looking slightly down
  // leans back by a few degrees at most).
  const double up_angle_deg =
      std::acos(std::clamp((e.truth_from_estimate.rotation * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0)) * 180 / M_PI;
  std::printf("synthetic: the estimated +Z is %.2f deg from the true +Z\n", up_angle_deg);
  EXPECT_LT(up_angle_deg, 3.0);

  // The same input gives the same cameras: matching, verification and mapping are deterministic (COLMAP's
  // final bundle adjustment leaves differences of about 1e-8 of the scene; before, runs differed by 2.5 %).
  const Reconstruction again = Reconstruction::Read(dir / "sfm_again/sparse");
  ASSERT_EQ(again.images.size(), model.images.size());
  for (const auto& [id, im] : model.images) {
    const ImageRecord* other = again.FindImage(im.name);
    ASSERT_NE(other, nullptr) << im.name;
    EXPECT_LT((other->ProjectionCenter() - im.ProjectionCenter()).norm(), 1e-6 * e.scene_radius) << im.name;
    EXPECT_LT(other->cam_from_world_rotation.angularDistance(im.cam_from_world_rotation), 1e-6) << im.name;
  }

  // What `auto` chooses for a large collection: the retrieval matcher (above sfm.exhaustive_max_photos) and the
  // hierarchical mapper (from 300 photos; here its one cluster holds every photo, so this checks that its runs,
  // the consensus between them and the global bundle adjustment after them hold together; the merging of
  // clusters is measured on 320 photos in docs/BENCHMARKS.md).
  // The retrieval matcher with 10 neighbours a photo: 160-168
  // of the 276 pairs, found by a vocabulary of the photos' own features although neighbouring photos never
  // share their light, then 34-44 more for the photos with fewer verified partners than the median photo
  // (RetrievalExpansion). Measured over seeds 0-5 (standing in for the small differences between machines):
  // 23-24 of 24 registered from 204-215 pairs; without the expansion 22-24, and one seed's run was stopped
  // as a split by a 3-photo model COLMAP had abandoned.
  const std::string retrieval_command = testing::BinDir() + "/sfm --input ingest=" + (dir / "ingest") +
                                        " --set sfm.matcher=retrieval --set sfm.retrieval_neighbors=10"
                                        " --set sfm.mapper=hierarchical --output " +
                                        (dir / "sfm_retrieval");
  ASSERT_EQ(testing::RunCommand(retrieval_command, &log), 0) << log;
  const Json retrieval = ReadJsonFile(dir / "sfm_retrieval/sfm_summary.json");
  EXPECT_EQ(retrieval.at("matcher"), "retrieval");
  EXPECT_EQ(retrieval.at("mapper"), "hierarchical");
  EXPECT_LT(retrieval.at("num_pairs_matched").get<int>(), 24 * 23 / 2);  // fewer than exhaustive matching
  EXPECT_GE(retrieval.at("num_registered").get<int>(), 23) << retrieval.at("unregistered").dump();
  const CameraErrors r = CompareCameras(Reconstruction::Read(dir / "sfm_retrieval/sparse"), truth);
  EXPECT_LE(r.median_rotation_deg, 0.5);
  EXPECT_LE(r.max_rotation_deg, 2.0);
  std::printf(
      "synthetic, retrieval matcher, hierarchical mapper: %d/%d registered from %d photo pairs, median rotation "
      "error %.3f deg\n",
      retrieval.at("num_registered").get<int>(), num_photos, retrieval.at("num_pairs_matched").get<int>(),
      r.median_rotation_deg);
}

}  // namespace
}  // namespace relight
