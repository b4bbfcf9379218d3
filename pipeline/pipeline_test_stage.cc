// A test stage for the orchestrator tests: sums upstream results, writes one
// file per item (atomically, skipping items already written: per-item resume)
// and appends each invocation to $TEST_STAGE_LOG. $TEST_STAGE_FAIL / $TEST_STAGE_CRASH
// name a stage that fails with a user error / dies of SIGSEGV after logging a line.
#include "pipeline/pipeline_test_stage.h"

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "core/fs.h"
#include "core/log.h"
#include "core/stage.h"

namespace {
struct TestStageSummary {
  int computed = 0;
  long total = 0;
  std::string BriefReport() const {
    return TEST_STAGE_NAME ": " + std::to_string(computed) + " items computed, total " + std::to_string(total);
  }
};
}  // namespace

int main(int argc, char** argv) {
  using namespace relight;
  using relight::pipeline::TestStageOptions;
  const StageInfo info{TEST_STAGE_NAME, "test stage", 1};
  return StageMain<TestStageOptions>(argc, argv, info, [](const TestStageOptions& o, const StageContext& ctx) {
    if (const char* log = std::getenv("TEST_STAGE_LOG")) std::ofstream(log, std::ios::app) << TEST_STAGE_NAME << "\n";
    RLOG_INFO("{} items to compute", o.items);
    if (std::getenv("TEST_STAGE_CRASH") && std::string(std::getenv("TEST_STAGE_CRASH")) == TEST_STAGE_NAME) {
      RLOG_INFO("crashing on request of TEST_STAGE_CRASH");
      std::raise(SIGSEGV);
    }
    if (std::getenv("TEST_STAGE_FAIL") && std::string(std::getenv("TEST_STAGE_FAIL")) == TEST_STAGE_NAME) {
      RELIGHT_USER_ERROR() << "failing on request of TEST_STAGE_FAIL";
    }
    if (o.fail) RELIGHT_USER_ERROR() << "asked to fail on input 'x.jpg'; remove it";
    if (o.memory_mib > 0) {
      std::vector<char> block(size_t(o.memory_mib) << 20);
      for (size_t k = 0; k < block.size(); k += 4096) block[k] = char(k);  // touch every page
      RLOG_INFO("touched {} MiB ({})", o.memory_mib, int(block[block.size() / 2]));
    }
    long total = o.value;
    for (const auto& [name, dir] : ctx.inputs) total += std::stol(ReadFileToString(JoinPath(dir, "result.txt")));
    int computed = 0;
    for (int i = 0; i < o.items; ++i) {
      const std::string item = ctx.OutputPath("item_" + std::to_string(i) + ".txt");
      if (std::filesystem::exists(item)) continue;  // finished by an earlier, killed run
      std::this_thread::sleep_for(std::chrono::milliseconds(o.sleep_ms));
      WriteFileAtomic(item, std::to_string(i));
      RLOG_INFO("item {} written", i);
      ++computed;
    }
    std::ofstream(ctx.OutputPath("computed.txt"), std::ios::app) << computed << "\n";
    WriteFileAtomic(ctx.OutputPath("result.txt"), std::to_string(total));
    return TestStageSummary{computed, total};
  });
}
