#include "core/process.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

ProcessOptions Lines(std::vector<std::string>* lines) {
  ProcessOptions options;
  options.output = ProcessOptions::Output::kLines;
  options.on_line = [lines](const std::string& line) { lines->push_back(line); };
  return options;
}

TEST(ProcessTest, MergedOutputArrivesLineByLineWithTheExitCode) {
  std::vector<std::string> lines;
  const ProcessResult r =
      RunProcess({"sh", "-c", "echo one; echo two >&2; printf 'three\\r\\n\\nfour'; exit 3"}, Lines(&lines));
  ASSERT_TRUE(r.started()) << r.start_error;
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.signaled);
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(lines, (std::vector<std::string>{"one", "two", "three", "four"}));  // empty line and \r dropped
  EXPECT_EQ(r.tail, lines);
  EXPECT_EQ(r.TailText(2), "three | four");
  EXPECT_EQ(r.DescribeWithOutput(1), "exit code 3: four");
  EXPECT_GT(r.peak_memory_mib, 0.0);
  EXPECT_GE(r.seconds, 0.0);
}

TEST(ProcessTest, TailKeepsTheLastTwentyLines) {
  std::vector<std::string> lines;
  const ProcessResult r =
      RunProcess({"sh", "-c", "i=1; while [ $i -le 30 ]; do echo $i; i=$((i+1)); done"}, Lines(&lines));
  ASSERT_TRUE(r.ok()) << r.Describe();
  EXPECT_EQ(lines.size(), 30u);
  ASSERT_EQ(r.tail.size(), 20u);
  EXPECT_EQ(r.tail.front(), "11");
  EXPECT_EQ(r.tail.back(), "30");
}

TEST(ProcessTest, AKilledChildIsReportedWithItsSignal) {
  std::vector<std::string> lines;
  const ProcessResult r = RunProcess({"sh", "-c", "kill -9 $$"}, Lines(&lines));
  ASSERT_TRUE(r.started());
  EXPECT_TRUE(r.signaled);
  EXPECT_EQ(r.signal, 9);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.Describe().find("killed by signal 9"), std::string::npos) << r.Describe();
}

TEST(ProcessTest, AMissingProgramIsToldApartFromOneThatExits127) {
  const ProcessResult missing = RunProcess({"relight-no-such-program"});
  EXPECT_FALSE(missing.started());
  EXPECT_FALSE(missing.ok());
  EXPECT_NE(missing.start_error.find("cannot execute 'relight-no-such-program'"), std::string::npos)
      << missing.start_error;
  EXPECT_EQ(missing.Describe(), missing.start_error);
  const ProcessResult missing_path = RunProcess({"/nonexistent/relight-tool"});
  EXPECT_FALSE(missing_path.started());

  const ProcessResult exits = RunProcess({"sh", "-c", "exit 127"});
  EXPECT_TRUE(exits.started()) << exits.start_error;
  EXPECT_EQ(exits.exit_code, 127);
}

TEST(ProcessTest, DefaultEnvironmentDoesNotOverrideTheCallers) {
  ASSERT_EQ(setenv("RELIGHT_PROCESS_TEST_SET", "ours", 1), 0);
  unsetenv("RELIGHT_PROCESS_TEST_UNSET");
  std::vector<std::string> lines;
  ProcessOptions options = Lines(&lines);
  options.default_env = {"RELIGHT_PROCESS_TEST_SET=default", "RELIGHT_PROCESS_TEST_UNSET=default"};
  const ProcessResult r =
      RunProcess({"sh", "-c", "echo $RELIGHT_PROCESS_TEST_SET $RELIGHT_PROCESS_TEST_UNSET"}, options);
  ASSERT_TRUE(r.ok()) << r.Describe();
  EXPECT_EQ(lines, (std::vector<std::string>{"ours default"}));
}

TEST(ProcessTest, RunsInTheGivenFolderAndNamesAMissingOne) {
  testing::TempDir dir;
  std::vector<std::string> lines;
  ProcessOptions options = Lines(&lines);
  options.working_dir = dir.path();
  const ProcessResult r = RunProcess({"pwd", "-P"}, options);
  ASSERT_TRUE(r.ok()) << r.Describe();
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(fs::path(lines[0]), fs::canonical(dir.path()));

  options.working_dir = dir / "missing";
  const ProcessResult missing = RunProcess({"pwd"}, options);
  EXPECT_FALSE(missing.started());
  EXPECT_NE(missing.start_error.find(dir / "missing"), std::string::npos) << missing.start_error;
}

TEST(ProcessTest, OnStartSeesTheRunningChildThenZero) {
  std::vector<pid_t> seen;
  ProcessOptions options;
  options.on_start = [&](pid_t pid) { seen.push_back(pid); };
  ASSERT_TRUE(RunProcess({"true"}, options).ok());
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_GT(seen[0], 0);
  EXPECT_EQ(seen[1], 0);
  seen.clear();
  RunProcess({"relight-no-such-program"}, options);
  EXPECT_TRUE(seen.empty());  // never started
}

TEST(ProcessTest, CaptureKeepsStdoutAndStderrApart) {
  const CommandOutput c = RunCommandCapture({"sh", "-c", "echo out; echo err >&2; exit 2"});
  EXPECT_EQ(c.exit_code, 2);
  EXPECT_EQ(c.out, "out\n");
  EXPECT_EQ(c.err, "err\n");
  const CommandOutput missing = RunCommandCapture({"relight-no-such-program"});
  EXPECT_EQ(missing.exit_code, 127);
  EXPECT_NE(missing.err.find("relight-no-such-program"), std::string::npos) << missing.err;
  // More than a pipe holds on both streams at once: read together, neither blocks the child.
  const CommandOutput big = RunCommandCapture(
      {"sh", "-c", "i=0; while [ $i -lt 20000 ]; do echo 0123456789; echo abcdefghij >&2; i=$((i+1)); done"});
  EXPECT_EQ(big.exit_code, 0);
  EXPECT_EQ(big.out.size(), 220000u);
  EXPECT_EQ(big.err.size(), 220000u);
}

}  // namespace
}  // namespace relight
