#include "core/progress.h"

#include <gtest/gtest.h>

#include <thread>
#include <vector>

namespace relight {
namespace {

TEST(ProgressTest, FormatSeconds) {
  EXPECT_EQ(Progress::FormatSeconds(3.21), "3.2s");
  EXPECT_EQ(Progress::FormatSeconds(65), "1m05s");
  EXPECT_EQ(Progress::FormatSeconds(7440), "2h04m");
  EXPECT_EQ(Progress::FormatSeconds(-1), "?");
}

TEST(ProgressTest, ConcurrentAdvanceIsSafe) {
  setenv("RELIGHT_PROGRESS", "plain", 1);
  Progress p("work", 4000);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 1000; ++i) p.Advance();
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(p.done(), 4000);
  p.Finish();
}

}  // namespace
}  // namespace relight
