// The DiLiGenT ball through the real stage chain (ingest -> ... -> inverse):
// 12 of the 96 photos, spread over the light positions, with the options of
// configs/diligent_ball.yaml (Haar) and configs/diligent_ball_sh.yaml (SH order
// 2); each recovered map's brightest lobe is compared with the calibrated light
// direction and its power with the calibrated intensity (docs/RESULTS.md has
// the full set's numbers these bounds sit above).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/fs.h"
#include "datasets/diligent.h"
#include "datasets/light_evaluation.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

const std::string kBall = "photometric/diligent_ball";

std::vector<std::string> Lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> out;
  std::string line;
  while (std::getline(in, line))
    if (!line.empty() && line != "\r") out.push_back(line);
  return out;
}

// A DiLiGenT folder holding every 8th photo of the ball (12 of 96), photos and mask linked.
void WriteSubset(const std::string& from, const std::string& to) {
  fs::create_directories(to);
  const auto names = Lines(from + "/filenames.txt");
  const auto dirs = Lines(from + "/light_directions.txt");
  const auto rgb = Lines(from + "/light_intensities.txt");
  ASSERT_EQ(names.size(), 96u);
  std::ofstream fn(to + "/filenames.txt"), fd(to + "/light_directions.txt"), fi(to + "/light_intensities.txt");
  for (size_t k = 3; k < names.size(); k += 8) {
    fn << names[k] << "\n";
    fd << dirs[k] << "\n";
    fi << rgb[k] << "\n";
    fs::create_symlink(from + "/" + names[k], to + "/" + names[k]);
  }
  fs::create_symlink(from + "/mask.png", to + "/mask.png");
}

// Runs the chain up to inverse with `config` (relative to configs/) on the subset in one shared
// workspace (the second config reuses the cached stages before inverse); returns its inverse folder.
std::string RunSubset(const testing::TempDir& dir, const std::string& config) {
  std::ofstream(dir / (config + ".yaml"))
      << "base: " << testing::SourceDir() << "/configs/" << config << ".yaml\ningest:\n  images: subset\n";
  std::string out;
  const int rc = testing::RunCommand(testing::BinDir() + "/pipeline run " + (dir / (config + ".yaml")) +
                                         " --until inverse --workspace " + (dir / "ws"),
                                     &out);
  EXPECT_EQ(rc, 0) << out;
  const std::string basis = config == "diligent_ball_sh" ? "\"sh\"" : "\"haar\"";
  for (const auto& entry : fs::directory_iterator(dir / "ws/cache/inverse"))
    if (fs::exists(entry.path() / "lighting.json") &&
        ReadFileToString((entry.path() / "lighting.json").string()).find("\"basis\": " + basis) != std::string::npos)
      return entry.path().string();
  ADD_FAILURE() << "no inverse output\n" << out;
  return "";
}

void Print(const char* what, const LightEvaluation& e) {
  std::printf("%s: median %.2f deg, p90 %.2f deg, Pearson %.3f %.3f %.3f\n", what, e.median_angle_deg, e.p90_angle_deg,
              e.pearson.x(), e.pearson.y(), e.pearson.z());
}

std::vector<KnownDirectionalLight> SubsetLights(const testing::TempDir& dir) {
  for (const auto& entry : fs::directory_iterator(dir / "ws/cache/ingest"))
    if (fs::exists(entry.path() / "import/ground_truth/lights.json"))
      return ReadDirectionalLights((entry.path() / "import/ground_truth/lights.json").string());
  ADD_FAILURE() << "no lights.json";
  return {};
}

class DiligentPipelineTest : public ::testing::Test {
 protected:
  void SetUp() override {
    setenv("RELIGHT_PROGRESS", "plain", 1);
    ASSERT_TRUE(testing::HasSharedData(kBall)) << "needs ../shared/data/" << kBall;
    WriteSubset(testing::SharedDataDir() + "/" + kBall, dir_ / "subset");
  }
  testing::TempDir dir_;
};

TEST_F(DiligentPipelineTest, HaarMapsFindTheCalibratedLights) {
  const std::string inverse = RunSubset(dir_, "diligent_ball");
  ASSERT_FALSE(inverse.empty());
  const LightEvaluation e = EvaluateDirectionalLights(inverse, SubsetLights(dir_));
  ASSERT_EQ(e.photos.size(), 12u);
  Print("haar", e);
  // Measured on these 12: median 1.86°, p90 4.07°, Pearson 0.988 / 0.983 / 0.993 (stage version 1:
  // 1.95°, 3.95°, 0.95-0.97; all 96: 1.79°, 3.33°, 0.995-0.996). The median bound is the target;
  // the others leave room for 12 samples.
  EXPECT_LT(e.median_angle_deg, 3.0);
  EXPECT_LT(e.p90_angle_deg, 6.0);
  for (int c = 0; c < 3; ++c) EXPECT_GT(e.pearson[c], 0.9) << "channel " << c;
}

TEST_F(DiligentPipelineTest, ShOrder2MapsTrackTheCalibratedIntensities) {
  const std::string inverse = RunSubset(dir_, "diligent_ball_sh");
  ASSERT_FALSE(inverse.empty());
  const LightEvaluation e = EvaluateDirectionalLights(inverse, SubsetLights(dir_));
  ASSERT_EQ(e.photos.size(), 12u);
  Print("sh2", e);
  // The baseline cannot form a point light (docs/RESULTS.md): its brightest lobe lands far beyond the
  // light and moves with small changes of the reflectance fit (these 12: median 8.7° and 21.3° with two
  // versions of the weight smoothing; all 96: 30°), so the direction bound only catches gross breakage
  // (a wrong frame scatters the errors over 60° and more). Its power follows the calibrated intensities
  // closely and stably (Pearson >= 0.997 on these 12 in every run).
  EXPECT_LT(e.median_angle_deg, 35.0);
  for (int c = 0; c < 3; ++c) EXPECT_GT(e.pearson[c], 0.98) << "channel " << c;
}

}  // namespace
}  // namespace relight
