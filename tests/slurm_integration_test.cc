// pipeline.executor: slurm on a real Slurm (issue 39): a single-node cluster on this machine
// (tools/slurm_local_cluster.sh: munge, slurmctld, slurmd), the CI scene's chain (configs/synthetic_tiny.yaml)
// submitted as jobs, the per-photo passes of mvs, linearize, observe and relight as job arrays of 4 shards. While
// mvs runs, the test cancels one running shard with scancel; the run must resubmit that shard alone and finish.
// Every stage's cache key must equal the local run's (chain_integration_test, which ctest runs at the same time and
// which leaves its workspace in RELIGHT_CHAIN_EXPORT and its exit status in RELIGHT_CHAIN_EXPORT.done), and every
// file of every stage must equal the local one, with the workspace's path replaced by the other's: byte for byte,
// except that OpenEXR images are compared by pixels (OpenImageIO stamps a DateTime) and JSON files without what
// describes a run rather than its result (seconds, reuse counts, peak memory, start and end). Logs, the HTML report
// page and its charts (they show the run's timings), Slurm's job files and the shards' logs are not results.
//
// The Slurm run starts from the local run's photos (its synthesize entry, the CI's photo generator rather than a
// stage of a user's run) and goes as far as observe; it then takes the local run's inverse entry into its cache as
// soon as the local run has written it (its key must be one the local run computed, that is, every input of the solve
// equal), and a second Slurm run goes on from there through relight, evaluate and report while the local run does the
// same. The solve is the one stage that runs as a single long job; on one CPU it doubled this test's time. That it
// gives the same bits on any thread count is solver_test's SolveIsBitIdenticalOnOneOrTwoThreads.
//
// Each job asks for 1 CPU, so the stages run on 1 thread where the local run used 2: the comparison also
// checks that no result depends on the thread count.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "core/fs.h"
#include "core/json.h"
#include "image/image.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

// What describes a run rather than its result.
bool IsRunDescription(const std::string& key) {
  for (const char* word : {"second", "reused", "rendered", "peak_memory", "started", "finished", "written"}) {
    if (key.find(word) != std::string::npos) return true;
  }
  return false;
}

Json WithoutRunDescription(const Json& j) {
  if (j.is_object()) {
    Json out = Json::object();
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (!IsRunDescription(it.key())) out[it.key()] = WithoutRunDescription(it.value());
    }
    return out;
  }
  if (j.is_array()) {
    Json out = Json::array();
    for (const Json& v : j) out.push_back(WithoutRunDescription(v));
    return out;
  }
  return j;
}

bool IsResultFile(const fs::path& relative) {
  const std::string first = relative.begin()->string();
  const std::string name = relative.filename().string();
  // The report's charts/ plot the run's timings (their data: seconds per stage and iteration).
  if (first == "slurm" || first == "shards" || first == "charts") return false;
  return name != "stage.log" && name != "status.json" && name != "config.yaml" && name != "key.txt" &&
         name != "error.txt" && relative.extension() != ".html";
}

// `text` with every occurrence of `from` replaced by `to`.
std::string ReplaceAll(std::string text, const std::string& from, const std::string& to) {
  for (size_t pos = 0; (pos = text.find(from, pos)) != std::string::npos; pos += to.size()) {
    text.replace(pos, from.size(), to);
  }
  return text;
}

// Differences between a stage's local and Slurm outputs, one line each.
// `local_ws` and `slurm_ws`: the two workspaces, whose paths appear in some outputs.
std::vector<std::string> CompareStage(const fs::path& local, const fs::path& slurm, const std::string& local_ws,
                                      const std::string& slurm_ws) {
  std::vector<std::string> diffs;
  for (const auto& entry : fs::recursive_directory_iterator(local)) {
    if (!entry.is_regular_file()) continue;
    const fs::path rel = fs::relative(entry.path(), local);
    if (!IsResultFile(rel)) continue;
    const fs::path other = slurm / rel;
    if (!fs::is_regular_file(other)) {
      diffs.push_back(rel.string() + ": missing in the Slurm run");
      continue;
    }
    const std::string a = ReadFileToString(entry.path().string());
    const std::string b = ReplaceAll(ReadFileToString(other.string()), slurm_ws, local_ws);
    if (rel.extension() == ".exr") {
      const Image ia = ReadImage(entry.path().string()), ib = ReadImage(other.string());
      if (ia.width != ib.width || ia.height != ib.height || ia.channels != ib.channels || ia.pixels != ib.pixels) {
        diffs.push_back(rel.string() + ": pixels differ");
      }
    } else if (rel.extension() == ".json") {
      if (WithoutRunDescription(Json::parse(a)) != WithoutRunDescription(Json::parse(b))) {
        diffs.push_back(rel.string() + ": JSON differs");
      }
    } else if (a != b) {
      diffs.push_back(rel.string() + ": bytes differ");
    }
  }
  return diffs;
}

// `field` of stage `name` in a summary.json.
std::string StageField(const Json& summary, const std::string& name, const std::string& field) {
  for (const Json& stage : summary["stages"])
    if (stage["name"] == name) return stage[field];
  ADD_FAILURE() << "no stage '" << name << "' in summary.json";
  return "";
}

// Waits until the local run has a finished entry of `stage` (under `key`; any key when empty) and returns its
// folder; empty if the local run ended (`done` written) without one, or after 30 minutes.
fs::path WaitForLocalEntry(const std::string& local_ws, const std::string& stage, const std::string& key,
                           const std::string& done) {
  const fs::path cache = fs::path(local_ws) / "cache" / stage;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::minutes(30);
  while (std::chrono::steady_clock::now() < give_up) {
    const bool ended = fs::is_regular_file(done);  // read before the entries: an entry written before it is seen
    std::error_code ec;
    for (fs::directory_iterator it(cache, ec), end; !ec && it != end; it.increment(ec)) {
      if (!key.empty() && it->path().filename() != key) continue;
      try {
        const Json status = ReadJsonFile((it->path() / "status.json").string());
        if (status.value("status", "") == "done") return it->path();
      } catch (const std::exception&) {  // not written yet
      }
    }
    if (ended) return {};
    std::this_thread::sleep_for(std::chrono::seconds(2));
  }
  return {};
}

// Copies a cache entry of the local run into the Slurm run's workspace, under the same key.
void CopyEntry(const fs::path& local_entry, const std::string& ws, const std::string& stage) {
  const fs::path cache = fs::path(ws) / "cache" / stage;
  fs::create_directories(cache);
  fs::copy(local_entry, cache / local_entry.filename(), fs::copy_options::recursive);
}

TEST(SlurmIntegrationTest, ChainOnSlurmEqualsLocalRunAndRerunsACancelledShard) {
  setenv("RELIGHT_PROGRESS", "plain", 1);
  const char* exported = std::getenv("RELIGHT_CHAIN_EXPORT");
  ASSERT_NE(exported, nullptr) << "RELIGHT_CHAIN_EXPORT is not set: run this test through ctest, together with "
                                  "chain_integration_test (ctest -R 'chain|slurm')";
  const std::string local_ws = fs::absolute(exported).lexically_normal().string();

  testing::TempDir temp;
  const std::string cluster = temp / "cluster";
  std::string out;
  ASSERT_EQ(
      testing::RunCommand("bash " + testing::SourceDir() + "/tools/slurm_local_cluster.sh start " + cluster, &out), 0)
      << out;
  setenv("SLURM_CONF", (cluster + "/slurm.conf").c_str(), 1);
  struct StopCluster {
    std::string dir;
    ~StopCluster() {
      testing::RunCommand("bash " + testing::SourceDir() + "/tools/slurm_local_cluster.sh stop " + dir);
    }
  } stop{cluster};

  const std::string ws = fs::absolute(temp / "ws").lexically_normal().string();
  const std::string config = testing::SourceDir() + "/configs/synthetic_tiny.yaml";
  const std::string run = testing::BinDir() + "/pipeline run " + config + " --workspace " + ws +
                          " --set pipeline.executor=slurm --set pipeline.slurm_shards=4"
                          " --set pipeline.slurm_cpus_per_task=1";
  // The photos: the local run's synthesize entry, taken into this run's cache once the local run has written it
  // (synthesize is the CI's photo generator, not a stage of a user's run; here it would render the same photos again
  // as one single-CPU job). Its key must be the one this run plans, checked below.
  const std::string done = std::string(exported) + ".done";
  const fs::path local_synthesize = WaitForLocalEntry(local_ws, "synthesize", "", done);
  ASSERT_FALSE(local_synthesize.empty()) << "chain_integration_test's local run wrote no synthesize entry in "
                                         << local_ws
                                         << " within 30 minutes (ctest runs the two together: ctest -R "
                                            "'chain|slurm')";
  CopyEntry(local_synthesize, ws, "synthesize");
  std::atomic<bool> finished{false};
  int rc = -1;
  std::string run_out;
  std::thread runner([&] {
    rc = testing::RunCommand(run + " --until observe", &run_out);
    finished = true;
  });
  // Cancel one running shard of mvs's first pass, once.
  std::string cancelled;
  while (!finished && cancelled.empty()) {
    std::string tasks;
    testing::RunCommand("squeue -h -r -t RUNNING -n relight-mvs-step0 -o %i", &tasks);
    std::istringstream lines(tasks);
    std::string task;
    if (lines >> task && task.find('_') != std::string::npos) {
      std::this_thread::sleep_for(std::chrono::seconds(3));  // let it write something first
      if (testing::RunCommand("scancel " + task) == 0) cancelled = task;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  runner.join();
  ASSERT_EQ(rc, 0) << run_out;
  ASSERT_FALSE(cancelled.empty()) << "no running mvs shard was seen to cancel\n" << run_out;
  EXPECT_NE(run_out.find("resubmitting it alone"), std::string::npos) << run_out;

  // The solve: the local run's entry under the key this run planned, as soon as the local run has it (the local run
  // goes on with relight, evaluate, report and its own checks meanwhile).
  {
    const Json planned = ReadJsonFile(ws + "/summary.json");
    ASSERT_EQ(StageField(planned, "synthesize", "key"), local_synthesize.filename().string())
        << "synthesize: this run planned another key than the local run's (its options differ)";
    const std::string inverse_key = StageField(planned, "inverse", "key");
    ASSERT_FALSE(inverse_key.empty());
    const fs::path local_inverse = WaitForLocalEntry(local_ws, "inverse", inverse_key, done);
    ASSERT_FALSE(local_inverse.empty())
        << "inverse: the local run ended or took over 30 minutes without an entry under this run's key " << inverse_key
        << " (its inputs differ, or it failed: " << local_ws << "/pipeline.log)";
    CopyEntry(local_inverse, ws, "inverse");
  }
  run_out.clear();
  ASSERT_EQ(testing::RunCommand(run, &run_out), 0) << run_out;

  // The local run's results, to compare with.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::minutes(30);
  while (!fs::is_regular_file(done) && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::seconds(5));
  }
  ASSERT_TRUE(fs::is_regular_file(done)) << "chain_integration_test's local run did not finish within 30 minutes of "
                                            "this run: ctest runs the two together (ctest -R 'chain|slurm')";
  ASSERT_EQ(ReadFileToString(done), "0") << "chain_integration_test's local run failed: nothing to compare with";
  ASSERT_TRUE(fs::is_regular_file(local_ws + "/summary.json")) << "no local run in " << local_ws;

  const Json summary = ReadJsonFile(ws + "/summary.json");
  int compared = 0;
  for (const Json& stage : summary["stages"]) {
    const std::string name = stage["name"], key = stage["key"];
    // The second Slurm run reran nothing it had: the stages up to observe and the solve are cached.
    const bool second_part = name == "relight" || name == "evaluate" || name == "report";
    ASSERT_EQ(stage["status"], second_part ? "done" : "cached") << name;
    const fs::path local_entry = fs::path(local_ws) / "cache" / name / key;
    ASSERT_TRUE(fs::is_regular_file(local_entry / "status.json"))
        << name << ": the Slurm run's key " << key << " is not a key of the local run";
    const std::vector<std::string> diffs =
        CompareStage(local_entry, stage["output_dir"].get<std::string>(), local_ws, ws);
    std::string text;
    for (size_t k = 0; k < diffs.size() && k < 10; ++k) text += "\n  " + diffs[k];
    EXPECT_TRUE(diffs.empty()) << name << ": " << diffs.size() << " files differ from the local run's:" << text;
    ++compared;
  }
  EXPECT_EQ(compared, 12);
  // The shards ran as job arrays: 5 passes of mvs, and relight's pass, each of 4 tasks.
  const std::string mvs_dir = StageField(summary, "mvs", "output_dir"),
                    relight_dir = StageField(summary, "relight", "output_dir");
  for (int i = 0; i < 4; ++i) {
    for (int step = 0; step < 5; ++step)
      EXPECT_TRUE(
          fs::is_regular_file(mvs_dir + "/slurm/step" + std::to_string(step) + "_" + std::to_string(i) + ".rc"));
    EXPECT_TRUE(fs::is_regular_file(relight_dir + "/slurm/step0_" + std::to_string(i) + ".rc")) << i;
  }
}

}  // namespace
}  // namespace relight
