// The `pipeline` executable end to end on real stages: exit codes and messages
// for bad input, caching across runs, status and clean.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/fs.h"
#include "core/json.h"
#include "image/image.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

class PipelineCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    setenv("RELIGHT_PROGRESS", "plain", 1);
    fs::create_directories(dir_ / "photos");
  }
  int Pipeline(const std::string& args, std::string* out) {
    return testing::RunCommand(testing::BinDir() + "/pipeline " + args, out);
  }
  void WriteConfig(const std::string& yaml) { std::ofstream(dir_ / "config.yaml") << yaml; }
  void AddPhotos(int n) {
    for (int i = 0; i < n; ++i) {
      Image img(64, 48, 3);
      for (size_t p = 0; p < img.pixels.size(); ++p) img.pixels[p] = static_cast<float>((p * (7 + i)) % 251) / 250.0f;
      WriteImage(dir_ / ("photos/p" + std::to_string(i) + ".jpg"), img);
    }
  }
  testing::TempDir dir_;
};

// The summary's entry for one stage (null Json if absent, which fails the comparisons).
Json StageEntry(const Json& summary, const std::string& name) {
  for (const Json& stage : summary["stages"]) {
    if (stage["name"] == name) return stage;
  }
  ADD_FAILURE() << "no stage '" << name << "' in summary.json";
  return Json();
}

TEST_F(PipelineCliTest, FolderWithOnlyBadFilesFailsWithClearReason) {
  Image big(256, 256, 3, 0.3f);
  for (size_t p = 0; p < big.pixels.size(); ++p) big.pixels[p] = static_cast<float>(p % 97) / 97.0f;
  WriteImage(dir_ / "full.jpg", big);
  const std::string bytes = ReadFileToString(dir_ / "full.jpg");
  std::ofstream(dir_ / "photos/truncated.jpg", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  std::ofstream(dir_ / "photos/text.jpg") << "not an image";
  std::ofstream(dir_ / "photos/zero.jpg");
  WriteConfig("ingest:\n  images: photos\n");
  std::string out;
  const int rc = Pipeline("run " + (dir_ / "config.yaml") + " --workspace " + (dir_ / "ws"), &out);
  EXPECT_EQ(rc, 1) << out;
  EXPECT_NE(out.find("stage 'ingest' failed"), std::string::npos) << out;
  EXPECT_NE(out.find("only 0 usable photo(s)"), std::string::npos) << out;
  EXPECT_NE(out.find("truncated.jpg"), std::string::npos) << out;
  const Json summary = ReadJsonFile(dir_ / "ws/summary.json");
  EXPECT_EQ(StageEntry(summary, "ingest")["status"], "failed");
}

TEST_F(PipelineCliTest, EmptyFolderAndMissingFolder) {
  WriteConfig("ingest:\n  images: photos\n");
  std::string out;
  EXPECT_EQ(Pipeline("run " + (dir_ / "config.yaml") + " --workspace " + (dir_ / "ws"), &out), 1);
  EXPECT_NE(out.find("contains no files"), std::string::npos) << out;
  WriteConfig("ingest:\n  images: nowhere\n");
  EXPECT_EQ(Pipeline("run " + (dir_ / "config.yaml") + " --workspace " + (dir_ / "ws"), &out), 2);
  EXPECT_NE(out.find("nowhere"), std::string::npos) << out;
}

TEST_F(PipelineCliTest, UnknownKeyAndBadValueNameFileAndLine) {
  AddPhotos(3);
  WriteConfig("# comment\ningest:\n  imagez: photos\n");
  std::string out;
  EXPECT_EQ(Pipeline("run " + (dir_ / "config.yaml"), &out), 2);
  EXPECT_NE(out.find("config.yaml:3: unknown option 'ingest.imagez'"), std::string::npos) << out;
  EXPECT_NE(out.find("images"), std::string::npos) << out;  // lists the allowed keys
  WriteConfig("ingest:\n  images: photos\n  max_image_size: -5\n");
  EXPECT_EQ(Pipeline("run " + (dir_ / "config.yaml"), &out), 2);
  EXPECT_NE(out.find("config.yaml:3"), std::string::npos) << out;
  EXPECT_NE(out.find(">= 0"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir_ / "workspace"));
}

TEST_F(PipelineCliTest, SecondRunIsCachedAndStatusAndCleanWork) {
  AddPhotos(3);
  WriteConfig("ingest:\n  images: photos\n");
  const std::string ws = " --workspace " + (dir_ / "ws");
  std::string out;
  ASSERT_EQ(Pipeline("run " + (dir_ / "config.yaml") + ws + " --until ingest", &out), 0) << out;
  ASSERT_EQ(Pipeline("run " + (dir_ / "config.yaml") + ws + " --until ingest", &out), 0) << out;
  const Json summary = ReadJsonFile(dir_ / "ws/summary.json");
  EXPECT_EQ(StageEntry(summary, "ingest")["status"], "cached");
  // Stages before ingest (synthesize) have nothing to do for a photo folder.
  EXPECT_EQ(StageEntry(summary, "synthesize")["status"], "skipped");
  EXPECT_TRUE(fs::exists(dir_ / "ws/stages/ingest/manifest.json"));
  ASSERT_EQ(Pipeline("status " + (dir_ / "config.yaml") + ws, &out), 0);
  EXPECT_NE(out.find("ingest      cached"), std::string::npos) << out;
  // A changed photo changes the key: the old entry stays until `clean --keep-latest`.
  AddPhotos(4);
  ASSERT_EQ(Pipeline("run " + (dir_ / "config.yaml") + ws + " --until ingest", &out), 0) << out;
  ASSERT_EQ(Pipeline("clean " + (dir_ / "config.yaml") + ws + " --keep-latest", &out), 0) << out;
  EXPECT_NE(out.find("removed 1 cache entry"), std::string::npos) << out;
  ASSERT_EQ(Pipeline("status " + (dir_ / "config.yaml") + ws, &out), 0);
  EXPECT_NE(out.find("ingest      cached"), std::string::npos) << out;
}

TEST_F(PipelineCliTest, StagesAndOptionsAreListed) {
  std::string out;
  ASSERT_EQ(Pipeline("stages", &out), 0);
  EXPECT_NE(out.find("ingest"), std::string::npos);
  ASSERT_EQ(Pipeline("options ingest --markdown", &out), 0);
  EXPECT_NE(out.find("`ingest.max_image_size`"), std::string::npos) << out;
  EXPECT_EQ(Pipeline("options nosuchstage", &out), 2);
}

// Every config the project ships resolves: known keys and values, existing inputs (the data of
// ../shared beside the checkout and Debian's blender-data, which tools/setup_debian.sh installs).
// configs/liberty.yaml reads a folder the user downloads, so there the message must name it.
TEST_F(PipelineCliTest, ShippedConfigsResolve) {
  int checked = 0;
  for (const auto& entry : fs::directory_iterator(testing::SourceDir() + "/configs")) {
    if (entry.path().extension() != ".yaml") continue;
    std::string out;
    const int rc = Pipeline("status " + entry.path().string() + " --workspace " + (dir_ / "ws"), &out);
    if (entry.path().filename() == "liberty.yaml" && !fs::exists(entry.path().parent_path() / "../../data/liberty")) {
      EXPECT_EQ(rc, 2) << out;
      EXPECT_NE(out.find("ingest.images"), std::string::npos) << out;
      EXPECT_NE(out.find("data/liberty"), std::string::npos) << out;
    } else {
      EXPECT_EQ(rc, 0) << entry.path() << ":\n" << out;
    }
    ++checked;
  }
  EXPECT_GE(checked, 9);
}

TEST_F(PipelineCliTest, ConfigReferenceIsUpToDate) {
  // configs/README.md embeds `pipeline options --markdown`; regenerate it with
  // tools/update_config_reference.sh after changing any option.
  std::string out;
  ASSERT_EQ(Pipeline("options --markdown", &out), 0);
  const std::string readme = ReadFileToString(testing::SourceDir() + "/configs/README.md");
  EXPECT_NE(readme.find(out), std::string::npos)
      << "configs/README.md is out of date: run tools/update_config_reference.sh";
}

}  // namespace
}  // namespace relight
