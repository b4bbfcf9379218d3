// The `pipeline` executable end to end on real stages: exit codes and messages
// for bad input, caching across runs, status and clean.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

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
      Image img(80, 64, 3);
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
  EXPECT_NE(out.find("contains no photos"), std::string::npos) << out;
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

// The slurm executor's --shard I/N reaches the stage executables; a malformed one is a user error, and a
// stage that cannot be sharded does not take the flag.
TEST_F(PipelineCliTest, MalformedShardIsRejected) {
  std::string out;
  for (const char* shard : {"1x/4", "1/4.5", "4/4", "-1/4", "3", "a/b", "1/0"}) {
    const int rc = testing::RunCommand(
        testing::BinDir() + "/linearize --shard " + shard + " --output " + (dir_ / "linearize"), &out);
    EXPECT_EQ(rc, 2) << shard << ": " << out;
    EXPECT_NE(out.find("expected I/N with 0 <= I < N"), std::string::npos) << shard << ": " << out;
  }
  EXPECT_EQ(testing::RunCommand(testing::BinDir() + "/inverse --shard 0/2 --output " + (dir_ / "inverse"), &out), 2);
  EXPECT_NE(out.find("--shard"), std::string::npos) << out;
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

TEST_F(PipelineCliTest, NonUtf8PhotoNamesAreTextInLogsJsonAndStatus) {
  AddPhotos(3);
  fs::rename(dir_ / "photos/p0.jpg", dir_ / "photos/Sacr\xe9 C\x9cur.jpg");  // a Latin-1 name
  std::ofstream(dir_ / "photos/d\xe9" "faut.jpg") << "broken";              // and a stage message quoting one
  WriteConfig("ingest:\n  images: photos\n");
  const std::string ws = " --workspace " + (dir_ / "ws");
  std::string out;
  // Before: "internal error (please report it): [json.exception.type_error.316] invalid UTF-8 byte", exit 3.
  ASSERT_EQ(Pipeline("run " + (dir_ / "config.yaml") + ws + " --until ingest", &out), 0) << out;
  EXPECT_NE(out.find("skipped '" + (dir_ / "photos/d\\xE9faut.jpg") + "'"), std::string::npos) << out;
  const Json manifest = ReadJsonFile(dir_ / "ws/stages/ingest/manifest.json");
  EXPECT_EQ(manifest["photos"][0]["name"], "Sacr\\xE9 C\\x9Cur.jpg");
  EXPECT_EQ(StageEntry(ReadJsonFile(dir_ / "ws/summary.json"), "ingest")["status"], "done");
  ASSERT_EQ(Pipeline("status " + (dir_ / "config.yaml") + ws, &out), 0) << out;
  EXPECT_NE(out.find("ingest      cached"), std::string::npos) << out;
  // A failing stage whose reason quotes such a name: exit 1, and summary.json is written.
  fs::remove(dir_ / "photos/p1.jpg");
  fs::remove(dir_ / "photos/p2.jpg");
  EXPECT_EQ(Pipeline("run " + (dir_ / "config.yaml") + ws + " --until ingest", &out), 1) << out;
  EXPECT_NE(out.find("d\\xE9faut.jpg"), std::string::npos) << out;
  const Json summary = ReadJsonFile(dir_ / "ws/summary.json");
  EXPECT_EQ(StageEntry(summary, "ingest")["status"], "failed");
  EXPECT_NE(StageEntry(summary, "ingest")["reason"].get<std::string>().find("only 1 usable photo(s)"),
            std::string::npos);
}

TEST_F(PipelineCliTest, FilesIngestDoesNotReadLeaveTheKeyAlone) {
  AddPhotos(3);
  WriteConfig("ingest:\n  images: photos\n");
  const std::string ws = " --workspace " + (dir_ / "ws");
  std::string out;
  ASSERT_EQ(Pipeline("run " + (dir_ / "config.yaml") + ws + " --until ingest", &out), 0) << out;
  fs::create_directories(dir_ / "photos/sub");
  std::ofstream(dir_ / "photos/notes.txt") << "where I took them";
  std::ofstream(dir_ / "photos/Thumbs.db") << "thumbnails";
  fs::copy_file(dir_ / "photos/p0.jpg", dir_ / "photos/sub/extra.jpg");  // not read: ingest.recursive is false
  ASSERT_EQ(Pipeline("status " + (dir_ / "config.yaml") + ws, &out), 0) << out;
  EXPECT_NE(out.find("ingest      cached"), std::string::npos) << out;
  ASSERT_EQ(Pipeline("status " + (dir_ / "config.yaml") + ws + " --set ingest.recursive=true", &out), 0) << out;
  EXPECT_NE(out.find("ingest      missing"), std::string::npos) << out;
  // The root folder: listed without descending (was "Permission denied [/proc/...]", exit 3).
  WriteConfig("ingest:\n  images: /\n");
  const int rc = Pipeline("run " + (dir_ / "config.yaml") + ws + " --until ingest", &out);
  EXPECT_EQ(rc, 1) << out;
  EXPECT_NE(out.find("photo folder '/' contains no photos"), std::string::npos) << out;
}

TEST_F(PipelineCliTest, MisleadingMessagesOfIssue34) {
  AddPhotos(3);
  std::string out;
  // ingest.images naming a file said "photo folder ... does not exist".
  WriteConfig("ingest:\n  images: photos/p0.jpg\n");
  EXPECT_EQ(Pipeline("status " + (dir_ / "config.yaml"), &out), 2) << out;
  EXPECT_NE(out.find("pipeline: error: ingest.images: '" + (dir_ / "photos/p0.jpg") +
                     "' is a file, not a folder; set it to the folder that holds the files"),
            std::string::npos)
      << out;
  // A folder in relight.envmaps said "install Debian's blender-data".
  fs::create_directories(dir_ / "maps");
  WriteConfig("ingest:\n  images: photos\nrelight:\n  envmaps: [maps]\n");
  EXPECT_EQ(Pipeline("status " + (dir_ / "config.yaml"), &out), 2) << out;
  EXPECT_NE(out.find("relight.envmaps: '" + (dir_ / "maps") + "' is a folder, not a file"), std::string::npos) << out;
  // `foo: 3` at the top level said "must be a mapping".
  WriteConfig("ingest:\n  images: photos\nfoo: 3\n");
  EXPECT_EQ(Pipeline("status " + (dir_ / "config.yaml"), &out), 2) << out;
  EXPECT_NE(out.find("config.yaml:3: unknown section 'foo'; allowed sections: "), std::string::npos) << out;
  // A second `mesh:` section was merged silently.
  WriteConfig("ingest:\n  images: photos\nmesh:\n  target_vertices: 1000\nmesh:\n  remesh_iterations: 2\n");
  EXPECT_EQ(Pipeline("status " + (dir_ / "config.yaml"), &out), 2) << out;
  EXPECT_NE(out.find("config.yaml:5: section 'mesh' appears twice in this file (first at "), std::string::npos) << out;
  // A missing CONFIG argument exited 106 (CLI11's own code).
  EXPECT_EQ(Pipeline("run", &out), 2) << out;
  EXPECT_NE(out.find("CONFIG is required"), std::string::npos) << out;
  EXPECT_EQ(Pipeline("status --workspace x", &out), 2) << out;
}

TEST_F(PipelineCliTest, CtrlCSaysWhatWasInterruptedAndHowToResume) {
  WriteConfig("synthesize:\n  num_photos: 400\n");  // minutes of rendering: interrupted long before the end
  const std::string ws = dir_ / "ws";
  const std::string script = "cd " + dir_.path() + " && (" + testing::BinDir() + "/pipeline run config.yaml --workspace " +
                             ws + " & p=$!; i=0; while ! ls " + ws +
                             "/cache/synthesize/*/stage.log >/dev/null 2>&1 && [ $i -lt 600 ]; do sleep 0.1; "
                             "i=$((i+1)); done; sleep 1; kill -INT $p; wait $p; echo \"exit=$?\")";
  std::string out;
  testing::RunCommand("sh -c '" + script + "'", &out);
  EXPECT_NE(out.find("exit=130"), std::string::npos) << out;  // was 130 with no message and no summary
  EXPECT_NE(out.find("pipeline: stage 'synthesize' was interrupted (interrupted by SIGINT after "), std::string::npos)
      << out;
  EXPECT_NE(out.find("pipeline: finished stages are cached; to resume: pipeline run config.yaml --workspace " + ws),
            std::string::npos)
      << out;
  const Json summary = ReadJsonFile(ws + "/summary.json");
  EXPECT_EQ(StageEntry(summary, "synthesize")["status"], "interrupted");
  EXPECT_EQ(StageEntry(summary, "ingest")["status"], "skipped");
  // pipeline.log keeps the run's lines (they were lost in its buffer).
  const std::string log = ReadFileToString(ws + "/pipeline.log");
  EXPECT_NE(log.find("synthesize: running"), std::string::npos) << log;
  EXPECT_NE(log.find("to resume: pipeline run config.yaml"), std::string::npos) << log;
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

// Every stage's public table fits on one screen; the rest is under "#### <stage> — advanced" (issue 35).
TEST_F(PipelineCliTest, PublicOptionsFitOnOneScreen) {
  std::string out;
  ASSERT_EQ(Pipeline("options --markdown", &out), 0);
  std::istringstream lines(out);
  std::string line, section;
  std::map<std::string, int> public_rows;
  bool in_public = false;
  while (std::getline(lines, line)) {
    if (line.rfind("### ", 0) == 0) {
      section = line.substr(4);
      in_public = true;
    } else if (line.rfind("#### ", 0) == 0) {
      in_public = false;
    } else if (in_public && line.rfind("| `", 0) == 0) {
      ++public_rows[section];
    }
  }
  EXPECT_GE(public_rows.size(), 10u) << out;
  for (const auto& [stage, rows] : public_rows) {
    if (stage.rfind("Measurement switches", 0) == 0) continue;
    EXPECT_LE(rows, 12) << stage << ": mark the options most runs leave alone .Advanced()";
  }
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
