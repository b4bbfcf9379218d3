// Orchestrator tests on four small test stages: alpha -> {beta, gamma} -> delta.
#include "pipeline/runner.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "pipeline/interrupt.h"
#include "pipeline/pipeline_test_stage.h"
#include "testing/testing.h"

namespace relight::pipeline {
namespace {
namespace fs = std::filesystem;

std::vector<StageDef> TestStages() {
  auto make = [](const std::string& name) {
    return [name] { return std::make_unique<TypedStageOptions<TestStageOptions>>(name); };
  };
  std::vector<StageDef> s;
  s.push_back({{"alpha", "first", 1}, "test_stage_alpha", {}, make("alpha"), nullptr, nullptr});
  s.push_back({{"beta", "second", 1}, "test_stage_beta", {"alpha"}, make("beta"), nullptr, nullptr});
  s.push_back({{"gamma", "sibling", 1}, "test_stage_gamma", {"alpha"}, make("gamma"), nullptr, nullptr});
  s.push_back({{"delta", "join", 1}, "test_stage_delta", {"beta", "gamma"}, make("delta"), nullptr, nullptr});
  return s;
}

class RunnerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    InitLogging("runner_test", "", LogLevel::kWarning);
    stages_ = TestStages();
    log_ = dir_ / "invocations.log";
    setenv("TEST_STAGE_LOG", log_.c_str(), 1);
    unsetenv("TEST_STAGE_FAIL");
    setenv("RELIGHT_PROGRESS", "off", 1);
    std::ofstream(dir_ / "raw.txt") << "raw input v1";
  }

  // Writes a config with the given body and runs/plans it.
  std::vector<StageRecord> Run(const std::string& yaml, const RunRequest& request = {}) {
    std::ofstream(dir_ / "config.yaml") << yaml;
    ResolvedConfig config(ConfigDocument::Load(dir_ / "config.yaml"), stages_);
    Runner runner(stages_, config, dir_ / "ws", testing::BinDir());
    return runner.Run(request);
  }
  std::vector<StageRecord> Plan(const std::string& yaml, const std::string& workspace = "ws") {
    std::ofstream(dir_ / "config.yaml") << yaml;
    ResolvedConfig config(ConfigDocument::Load(dir_ / "config.yaml"), stages_);
    Runner runner(stages_, config, dir_ / workspace, testing::BinDir());
    return runner.Plan();
  }
  std::string Invocations() {
    std::ifstream in(log_);
    std::string all, line;
    while (std::getline(in, line)) all += line + " ";
    fs::remove(log_);
    return all;
  }
  static std::string Statuses(const std::vector<StageRecord>& records) {
    std::string s;
    for (const auto& r : records) s += r.name + ":" + r.status + " ";
    return s;
  }
  static const StageRecord& Find(const std::vector<StageRecord>& records, const std::string& name) {
    for (const auto& r : records)
      if (r.name == name) return r;
    throw std::runtime_error("no record " + name);
  }

  testing::TempDir dir_;
  std::vector<StageDef> stages_;
  std::string log_;
  const std::string base_ = "alpha:\n  value: 1\n  input: raw.txt\nbeta:\n  value: 10\ngamma:\n  value: 100\n";
};

TEST_F(RunnerTest, KeysAreStableAcrossRunsOrderAndWorkspace) {
  const auto a = Plan(base_);
  const auto b = Plan(base_);
  const auto reordered = Plan("gamma.value: 100\nbeta:\n  value: 10\nalpha:\n  input: raw.txt\n  value: 1\n");
  const auto other_ws = Plan(base_, "elsewhere");
  const auto with_note = Plan(base_ + "delta:\n  note: not in key\n  sleep_ms: 5\n");
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].key.size(), 64u);
    EXPECT_EQ(a[i].key, b[i].key) << a[i].name;
    EXPECT_EQ(a[i].key, reordered[i].key) << a[i].name;
    EXPECT_EQ(a[i].key, other_ws[i].key) << a[i].name;
    EXPECT_EQ(a[i].key, with_note[i].key) << a[i].name;
  }
  // Distinct stages never share a key, even with identical options.
  EXPECT_NE(Find(a, "beta").key, Find(a, "gamma").key);
}

TEST_F(RunnerTest, SecondRunReusesEverything) {
  auto first = Run(base_);
  EXPECT_EQ(Statuses(first), "alpha:done beta:done gamma:done delta:done ");
  EXPECT_EQ(Invocations(), "alpha beta gamma delta ");
  EXPECT_EQ(ReadFileToString(Find(first, "delta").output_dir + "/result.txt"), "113");  // delta 1 + beta (10+1) + gamma (100+1)
  auto second = Run(base_);
  EXPECT_EQ(Statuses(second), "alpha:cached beta:cached gamma:cached delta:cached ");
  EXPECT_EQ(Invocations(), "");
  // summary.json mirrors the records.
  const Json summary = ReadJsonFile(dir_ / "ws/summary.json");
  ASSERT_EQ(summary["stages"].size(), 4u);
  EXPECT_EQ(summary["stages"][3]["status"], "cached");
  EXPECT_EQ(summary["stages"][3]["key"], Find(second, "delta").key);
  EXPECT_TRUE(fs::exists(dir_ / "ws/stages/delta/result.txt"));
  // The resolved config and the hashed text are kept beside the outputs.
  EXPECT_NE(ReadFileToString(Find(first, "beta").output_dir + "/config.yaml").find("value: 10"), std::string::npos);
  EXPECT_NE(ReadFileToString(Find(first, "beta").output_dir + "/key.txt").find("upstream alpha="), std::string::npos);
}

// Each stage's peak memory (its process tree's largest resident set) is recorded in status.json and
// summary.json, and read back with the cached result.
TEST_F(RunnerTest, PeakMemoryOfEachStageIsRecorded) {
  const std::string yaml =
      "alpha:\n  value: 1\n  input: raw.txt\nbeta:\n  value: 10\n  memory_mib: 160\ngamma:\n  value: 100\n";
  const auto first = Run(yaml);
  const Json beta = ReadJsonFile(Find(first, "beta").output_dir + "/status.json");
  const Json alpha = ReadJsonFile(Find(first, "alpha").output_dir + "/status.json");
  // The 160 MiB block plus the process itself (libraries, a few MiB); alpha holds no block.
  EXPECT_GE(beta["peak_memory_mib"].get<double>(), 160.0);
  EXPECT_LT(beta["peak_memory_mib"].get<double>(), 160.0 + 64);
  EXPECT_GT(alpha["peak_memory_mib"].get<double>(), 0.5);
  EXPECT_LT(alpha["peak_memory_mib"].get<double>(), 64.0);
  const Json summary = ReadJsonFile(dir_ / "ws/summary.json");
  EXPECT_DOUBLE_EQ(summary["stages"][1]["peak_memory_mib"].get<double>(), beta["peak_memory_mib"].get<double>());
  const auto second = Run(yaml);
  EXPECT_EQ(Find(second, "beta").status, "cached");
  EXPECT_DOUBLE_EQ(Find(second, "beta").peak_memory_mib, beta["peak_memory_mib"].get<double>());
}

TEST_F(RunnerTest, ChangedOptionRerunsStageAndDownstreamOnly) {
  Run(base_);
  Invocations();
  auto records = Run("alpha:\n  value: 1\n  input: raw.txt\nbeta:\n  value: 11\ngamma:\n  value: 100\n");
  EXPECT_EQ(Statuses(records), "alpha:cached beta:done gamma:cached delta:done ");
  EXPECT_EQ(Invocations(), "beta delta ");
  EXPECT_EQ(ReadFileToString(Find(records, "delta").output_dir + "/result.txt"), "114");
  // The old entries stay until `clean`.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "ws/cache/beta"), fs::directory_iterator()), 2);
}

TEST_F(RunnerTest, RawInputsEnterKeysByContent) {
  Run(base_);
  Invocations();
  // Same content, new modification time: nothing reruns.
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  std::ofstream(dir_ / "raw.txt") << "raw input v1";
  EXPECT_EQ(Statuses(Run(base_)), "alpha:cached beta:cached gamma:cached delta:cached ");
  std::ofstream(dir_ / "raw.txt") << "raw input v2";
  EXPECT_EQ(Statuses(Run(base_)), "alpha:done beta:done gamma:done delta:done ");
  // A missing input: the message names the option and the path.
  try {
    Run("alpha:\n  value: 1\n  input: missing.txt\n");
    ADD_FAILURE() << "a missing input must fail";
  } catch (const UserError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("alpha.input"), std::string::npos) << what;
    EXPECT_NE(what.find("missing.txt"), std::string::npos) << what;
  }
}

TEST_F(RunnerTest, KilledStageResumesPerItemAndKeepsFinishedStages) {
  const std::string slow = base_ + "beta.items: 40\nbeta.sleep_ms: 50\n";
  std::atomic<bool> stop{false};
  // The cache exists before the watcher walks it; the walk itself races the
  // runner's atomic renames, so a directory vanishing mid-walk only restarts it.
  fs::create_directories(dir_ / "ws/cache");
  std::thread killer([&] {
    // Kill beta once it has written a few items.
    while (!stop) {
      std::error_code ec;
      fs::recursive_directory_iterator it(dir_ / "ws/cache", fs::directory_options::skip_permission_denied, ec);
      for (; !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
        const fs::path& path = it->path();
        if (path.filename() == "item_5.txt" && path.string().find("/beta/") != std::string::npos) {
          testing::RunCommand("pkill -9 -f test_stage_beta");
          return;
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  auto killed = Run(slow);
  stop = true;
  killer.join();
  EXPECT_EQ(Find(killed, "alpha").status, "done");
  EXPECT_EQ(Find(killed, "beta").status, "failed");
  EXPECT_NE(Find(killed, "beta").reason.find("signal 9"), std::string::npos) << Find(killed, "beta").reason;
  EXPECT_EQ(Find(killed, "delta").status, "skipped");
  const std::string beta_dir = Find(killed, "beta").output_dir;
  EXPECT_FALSE(fs::exists(beta_dir + "/status.json"));
  Invocations();

  auto resumed = Run(slow);
  EXPECT_EQ(Statuses(resumed), "alpha:cached beta:done gamma:done delta:done ");
  // The resumed run computed only the items the killed run had not finished.
  std::ifstream computed(beta_dir + "/computed.txt");
  int n = -1;
  computed >> n;
  EXPECT_GT(n, 0);
  EXPECT_LT(n, 40);
  EXPECT_FALSE(fs::exists(beta_dir + "/error.txt"));
  for (int i = 0; i < 40; ++i) EXPECT_TRUE(fs::exists(beta_dir + "/item_" + std::to_string(i) + ".txt"));
}

// Waits (up to 20 s) until a file named `name` exists below the workspace's cache/<stage>.
bool WaitForItem(const std::string& cache, const std::string& stage, const std::string& name) {
  for (int tries = 0; tries < 4000; ++tries) {
    std::error_code ec;
    fs::recursive_directory_iterator it(cache + "/" + stage, fs::directory_options::skip_permission_denied, ec);
    for (; !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
      if (it->path().filename() == name) return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

TEST_F(RunnerTest, InterruptedStageIsRecordedKeepsItsLogAndTheRerunResumes) {
  InstallInterruptHandler();
  const std::string slow = base_ + "beta.items: 40\nbeta.sleep_ms: 50\n";
  fs::create_directories(dir_ / "ws/cache");
  std::thread ctrl_c([&] {
    // Ctrl-C once item 4 exists: the stage logs "item 3 written" before it starts item 4, whereas
    // between writing an item and logging it a signal may land (seen on a loaded CI machine).
    if (WaitForItem(dir_ / "ws/cache", "beta", "item_4.txt")) ::kill(::getpid(), SIGINT);
  });
  auto interrupted = Run(slow);
  ctrl_c.join();
  ASSERT_EQ(InterruptSignal(), SIGINT);
  ClearInterrupt();
  EXPECT_EQ(Statuses(interrupted), "alpha:done beta:interrupted gamma:skipped delta:skipped ");
  const StageRecord& beta = Find(interrupted, "beta");
  EXPECT_EQ(beta.reason.rfind("interrupted by SIGINT after ", 0), 0u) << beta.reason;
  EXPECT_NE(beta.reason.find("; the next run resumes it in the same folder"), std::string::npos) << beta.reason;
  EXPECT_EQ(Find(interrupted, "gamma").reason, "not reached: the run was interrupted");
  // summary.json says so (it said `cached` before), and nothing of beta counts as done.
  const Json summary = ReadJsonFile(dir_ / "ws/summary.json");
  EXPECT_EQ(summary["stages"][1]["status"], "interrupted");
  EXPECT_EQ(summary["stages"][1]["reason"], beta.reason);
  EXPECT_FALSE(fs::exists(beta.output_dir + "/status.json"));
  const std::string first_log = ReadFileToString(beta.output_dir + "/stage.log");
  EXPECT_NE(first_log.find("item 3 written"), std::string::npos) << first_log;
  EXPECT_NE(first_log.find("pipeline: " + beta.reason + " ===="), std::string::npos) << first_log;
  Invocations();

  auto resumed = Run(slow);
  EXPECT_EQ(Statuses(resumed), "alpha:cached beta:done gamma:done delta:done ");
  int computed_now = -1;
  std::ifstream(beta.output_dir + "/computed.txt") >> computed_now;  // the interrupted run wrote none
  EXPECT_GT(computed_now, 0);
  EXPECT_LE(computed_now, 35);  // items 0-4 were kept
  // The resumed run appended to the log: the interrupted run's lines are still there.
  const std::string log = ReadFileToString(beta.output_dir + "/stage.log");
  EXPECT_EQ(log.rfind(first_log, 0), 0u);
  EXPECT_NE(log.find("item 39 written"), std::string::npos);
}

TEST_F(RunnerTest, InterruptedForcedRerunKeepsTheOldResultAndBothLogs) {
  auto first = Run(base_ + "beta.items: 40\n");
  const std::string beta_dir = Find(first, "beta").output_dir;
  const std::string old_log = ReadFileToString(beta_dir + "/stage.log");
  InstallInterruptHandler();
  RunRequest force;
  force.force = {"beta"};
  // SIGTERM once the rerun (beside the finished entry) has written four items, so item 2 is logged.
  std::thread ctrl_c([&] {
    for (int i = 0; i < 4000 && !fs::exists(beta_dir + ".rerun/item_3.txt"); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ::kill(::getpid(), SIGTERM);
  });
  auto interrupted = Run(base_ + "beta.items: 40\nbeta.sleep_ms: 50\n", force);
  ctrl_c.join();
  ClearInterrupt();
  EXPECT_EQ(Find(interrupted, "beta").status, "interrupted");
  EXPECT_NE(Find(interrupted, "beta").reason.find("SIGTERM"), std::string::npos);
  EXPECT_NE(Find(interrupted, "beta").reason.find("the earlier result is kept"), std::string::npos);
  // The finished result and its log are untouched.
  EXPECT_TRUE(Runner::IsDone(beta_dir, Find(first, "beta").key));
  EXPECT_EQ(ReadFileToString(beta_dir + "/result.txt"), "11");
  EXPECT_EQ(ReadFileToString(beta_dir + "/stage.log"), old_log);
  const std::string interrupted_log = ReadFileToString(beta_dir + ".rerun/stage.log");
  EXPECT_NE(interrupted_log.find("item 2 written"), std::string::npos) << interrupted_log;
  // A second forced rerun starts afresh but keeps the interrupted attempt's log at the top.
  auto rerun = Run(base_ + "beta.items: 40\n", force);
  EXPECT_EQ(Find(rerun, "beta").status, "done");
  const std::string log = ReadFileToString(beta_dir + "/stage.log");
  EXPECT_EQ(log.rfind(interrupted_log, 0), 0u) << log;
  EXPECT_NE(log.find("pipeline: new run of stage beta"), std::string::npos) << log;
}

TEST_F(RunnerTest, CrashedStageKeepsWhatItLoggedAndSaysHowItDied) {
  setenv("TEST_STAGE_CRASH", "gamma", 1);
  auto crashed = Run(base_);
  unsetenv("TEST_STAGE_CRASH");
  const StageRecord& gamma = Find(crashed, "gamma");
  EXPECT_EQ(gamma.status, "failed");
  EXPECT_EQ(gamma.reason, "killed by signal 11 (Segmentation fault)");  // once: it was doubled in the console line
  const std::string log = ReadFileToString(gamma.output_dir + "/stage.log");
  EXPECT_NE(log.find("crashing on request of TEST_STAGE_CRASH"), std::string::npos) << log;
  EXPECT_NE(log.find("gamma: error: crashed with signal 11 (Segmentation fault); backtrace:"), std::string::npos)
      << log;
}

TEST_F(RunnerTest, FailureNamesReasonAndKeepsEarlierResults) {
  auto failed = Run(base_ + "gamma.fail: true\n");
  EXPECT_EQ(Find(failed, "gamma").status, "failed");
  EXPECT_NE(Find(failed, "gamma").reason.find("x.jpg"), std::string::npos);
  EXPECT_EQ(Find(failed, "delta").status, "skipped");
  Invocations();
  auto fixed = Run(base_);
  EXPECT_EQ(Statuses(fixed), "alpha:cached beta:cached gamma:done delta:done ");
}

TEST_F(RunnerTest, FailedForcedRerunKeepsThePreviousResult) {
  auto first = Run(base_);
  const std::string alpha_dir = Find(first, "alpha").output_dir;
  setenv("TEST_STAGE_FAIL", "alpha", 1);
  RunRequest force;
  force.force = {"alpha"};
  auto rerun = Run(base_, force);
  EXPECT_EQ(Find(rerun, "alpha").status, "failed");
  EXPECT_TRUE(Runner::IsDone(alpha_dir, Find(first, "alpha").key));
  EXPECT_EQ(ReadFileToString(alpha_dir + "/result.txt"), "1");
  unsetenv("TEST_STAGE_FAIL");
  Invocations();
  auto ok = Run(base_, force);
  // The new result replaces the old one under the same key, so everything computed from it reruns.
  EXPECT_EQ(Statuses(ok), "alpha:done beta:done gamma:done delta:done ");
  EXPECT_EQ(Invocations(), "alpha beta gamma delta ");
}

TEST_F(RunnerTest, ForcedRerunInvalidatesDownstreamResultsThisRunDoesNotReach) {
  Run(base_);
  Invocations();
  RunRequest force;
  force.force = {"beta"};
  force.until = "beta";
  auto records = Run(base_, force);
  EXPECT_EQ(Statuses(records), "alpha:cached beta:done gamma:cached delta:stale ");
  EXPECT_EQ(Invocations(), "beta ");
  EXPECT_NE(Find(records, "delta").reason.find("'beta' was rerun"), std::string::npos) << Find(records, "delta").reason;
  // The next full run recomputes delta from the new beta, and only delta.
  auto next = Run(base_);
  EXPECT_EQ(Statuses(next), "alpha:cached beta:cached gamma:cached delta:done ");
  EXPECT_EQ(Invocations(), "delta ");
}

TEST_F(RunnerTest, FromOnlyUntil) {
  RunRequest until;
  until.until = "beta";
  EXPECT_EQ(Statuses(Run(base_, until)), "alpha:done beta:done gamma:skipped delta:skipped ");
  Invocations();
  RunRequest only;
  only.only = "delta";
  EXPECT_THROW(Run(base_, only), UserError);  // gamma has no result yet
  Run(base_);
  Invocations();
  EXPECT_EQ(Statuses(Run(base_, only)), "alpha:cached beta:cached gamma:cached delta:done ");
  EXPECT_EQ(Invocations(), "delta ");
  RunRequest from;
  from.from = "gamma";
  EXPECT_EQ(Statuses(Run(base_, from)), "alpha:cached beta:cached gamma:done delta:done ");
  EXPECT_EQ(Invocations(), "gamma delta ");
  RunRequest bad;
  bad.from = "nope";
  EXPECT_THROW(Run(base_, bad), UserError);
}

TEST_F(RunnerTest, UnknownKeysAndBadValuesFailBeforeRunning) {
  try {
    Run(base_ + "delta:\n  note: x\n  valeu: 3\n");
    FAIL();
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("config.yaml:10"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("delta.valeu"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Run(base_ + "beta.items: -1\n"), UserError);
  EXPECT_THROW(Run(base_ + "epsilon:\n  value: 1\n"), UserError);
  EXPECT_EQ(Invocations(), "");
}

TEST_F(RunnerTest, CleanKeepLatest) {
  Run(base_);
  Run("alpha:\n  value: 2\n  input: raw.txt\n");
  std::ofstream(dir_ / "config.yaml") << "alpha:\n  value: 2\n  input: raw.txt\n";
  ResolvedConfig config(ConfigDocument::Load(dir_ / "config.yaml"), stages_);
  Runner runner(stages_, config, dir_ / "ws", testing::BinDir());
  EXPECT_EQ(runner.Clean(/*keep_latest=*/true), 4);
  for (const auto& r : runner.Plan()) EXPECT_EQ(r.status, "cached") << r.name;
  EXPECT_EQ(runner.Clean(false), 4);
  for (const auto& r : runner.Plan()) EXPECT_EQ(r.status, "missing") << r.name;
}

}  // namespace
}  // namespace relight::pipeline
