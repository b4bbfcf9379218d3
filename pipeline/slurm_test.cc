// The Slurm executor's submit / wait / resubmit logic against stand-ins for sbatch, squeue and scancel
// (shell scripts on PATH that run each array task as a background process), so it runs in seconds without
// a cluster. The real Slurm is exercised by tests/slurm_integration_test.cc.
#include "pipeline/slurm.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "core/fs.h"
#include "testing/testing.h"

namespace relight::pipeline {
namespace {
namespace fs = std::filesystem;

// sbatch: runs every task of --array in the background (SLURM_ARRAY_TASK_ID set, output to --output with %a
// replaced), records the pids under $FAKE_SLURM/<job>.pids, prints the job id. A task listed in
// $FAKE_SLURM/kill_once is killed right after it starts, once per line there (a cancelled task).
constexpr const char* kSbatch = R"(#!/bin/bash
state=$FAKE_SLURM
echo "$*" >> "$state/sbatch_calls"
id=$(( $(cat "$state/next_id" 2>/dev/null || echo 100) + 1 )); echo $id > "$state/next_id"
for a in "$@"; do
  case $a in --array=*) array=${a#--array=};; --output=*) out=${a#--output=};; esac
  script=$a
done
: > "$state/$id.pids"
for i in ${array//,/ }; do
  if [ -n "$FAKE_ELSEWHERE" ]; then sleep 0.2 & echo $! >> "$state/$id.pids"; continue; fi  # ran on a node we do not see
  : > "${out//%a/$i}"  # Slurm creates the output file before the task runs
  SLURM_ARRAY_TASK_ID=$i bash "$script" >> "${out//%a/$i}" 2>&1 &
  pid=$!
  echo $pid >> "$state/$id.pids"
  if grep -qx "$i" "$state/kill_once" 2>/dev/null; then
    sed -i "0,/^$i\$/{/^$i\$/d}" "$state/kill_once"
    kill -9 $pid
  fi
done
echo "$id;cluster"
)";
constexpr const char* kSqueue = R"(#!/bin/bash
while [ $# -gt 0 ]; do [ "$1" = -j ] && id=$2; shift; done
while read -r pid; do kill -0 "$pid" 2>/dev/null && echo "${id} RUNNING"; done < "$FAKE_SLURM/$id.pids"
exit 0
)";
constexpr const char* kScancel = R"(#!/bin/bash
while read -r pid; do kill -9 "$pid" 2>/dev/null; done < "$FAKE_SLURM/$1.pids"
)";

// A stage: with --shard=I/N writes done_I (and fails with a reason when I is in $FAIL_SHARD); whole, writes
// summary.
constexpr const char* kStage = R"(#!/bin/bash
for a in "$@"; do
  case $a in --shard=*) s=${a#--shard=}; shard=${s%/*};; --output=*) out=${a#--output=};; esac
done
sleep 0.3
if [ -n "$shard" ]; then
  if [ "$shard" = "$FAIL_SHARD" ]; then
    mkdir -p "$out/shards"; echo "photo_$shard.jpg is not an image" > "$out/shards/step0_$shard.error.txt"; exit 2
  fi
  echo ok > "$out/done_$shard"
else
  ls "$out" | grep -c '^done_' > "$out/summary"
fi
)";

class SlurmExecutorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    bin_ = temp_ / "bin";
    state_ = temp_ / "state";
    out_ = temp_ / "out";
    EnsureDir(bin_);
    EnsureDir(state_);
    EnsureDir(out_);
    for (const auto& [name, text] :
         {std::pair{"sbatch", kSbatch}, {"squeue", kSqueue}, {"scancel", kScancel}, {"stage", kStage}}) {
      WriteFileAtomic(bin_ + "/" + name, text);
      fs::permissions(bin_ + "/" + name, fs::perms::owner_all);
    }
    old_path_ = std::getenv("PATH");
    setenv("PATH", (bin_ + ":" + old_path_).c_str(), 1);
    setenv("FAKE_SLURM", state_.c_str(), 1);
    unsetenv("FAIL_SHARD");
    unsetenv("FAKE_ELSEWHERE");
    options_.shards = 4;
    options_.poll_seconds = 0.1;
    work_.stage = "observe";
    work_.argv = {bin_ + "/stage", "--output=" + out_};
    work_.output_dir = out_;
    work_.shard_steps = 1;
  }
  void TearDown() override { setenv("PATH", old_path_.c_str(), 1); }

  testing::TempDir temp_;
  std::string bin_, state_, out_, old_path_;
  SlurmOptions options_;
  SlurmStageWork work_;
};

TEST_F(SlurmExecutorTest, RunsEveryShardThenTheWholeStage) {
  const ProcessResult r = RunOnSlurm(work_, options_);
  ASSERT_TRUE(r.ok()) << r.Describe();
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(fs::exists(out_ + "/done_" + std::to_string(i))) << i;
  EXPECT_EQ(ReadFileToString(out_ + "/summary"), "4\n");  // the whole run came after every shard
  const std::string calls = ReadFileToString(state_ + "/sbatch_calls");
  EXPECT_NE(calls.find("--array=0,1,2,3 --cpus-per-task=2"), std::string::npos) << calls;
  EXPECT_NE(calls.find("--array=0 "), std::string::npos) << calls;
}

TEST_F(SlurmExecutorTest, ResubmitsAKilledShardAlone) {
  WriteFileAtomic(state_ + "/kill_once", "2\n");
  const ProcessResult r = RunOnSlurm(work_, options_);
  ASSERT_TRUE(r.ok()) << r.Describe();
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(fs::exists(out_ + "/done_" + std::to_string(i))) << i;
  const std::string calls = ReadFileToString(state_ + "/sbatch_calls");
  EXPECT_NE(calls.find("--array=2 "), std::string::npos) << "task 2 was not resubmitted alone:\n" << calls;
}

TEST_F(SlurmExecutorTest, AShardThatFailsFailsTheStageWithItsReason) {
  setenv("FAIL_SHARD", "1", 1);
  const ProcessResult r = RunOnSlurm(work_, options_);
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(ReadFileToString(out_ + "/error.txt"), "pass 1 of 1, 4 shards, task 1: photo_1.jpg is not an image\n");
  EXPECT_FALSE(fs::exists(out_ + "/summary"));  // the whole run never started
}

TEST_F(SlurmExecutorTest, GivesUpOnATaskKilledOnEveryAttempt) {
  options_.shards = 1;
  WriteFileAtomic(state_ + "/kill_once", "0\n0\n0\n");
  const ProcessResult r = RunOnSlurm(work_, options_);
  EXPECT_FALSE(r.ok());
  const std::string error = ReadFileToString(out_ + "/error.txt");
  EXPECT_NE(error.find("was killed 3 times"), std::string::npos) << error;
}

TEST_F(SlurmExecutorTest, AWorkspaceTheNodesDoNotShareIsNamed) {
  options_.shards = 1;
  setenv("FAKE_ELSEWHERE", "1", 1);  // the tasks run, but nothing they write appears here
  const ProcessResult r = RunOnSlurm(work_, options_);
  EXPECT_FALSE(r.ok());
  const std::string error = ReadFileToString(out_ + "/error.txt");
  EXPECT_NE(error.find("the workspace must be on a file system the compute nodes share"), std::string::npos) << error;
}

TEST_F(SlurmExecutorTest, MissingSbatchIsAClearError) {
  setenv("PATH", "/nonexistent", 1);
  try {
    RunOnSlurm(work_, options_);
    FAIL() << "no error";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("needs Slurm's `sbatch` on PATH"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace relight::pipeline
