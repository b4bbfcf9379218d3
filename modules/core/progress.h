// Progress reporting for long steps.
//
// On a terminal (stderr is a TTY) a one-line bar with percentage, counts,
// elapsed time and ETA, redrawn at most 10 times a second, appears once a step
// has run for more than a second. Otherwise (pipes, CI, log files) plain log
// lines at every 10% and at most every 30 s. The environment variable
// RELIGHT_PROGRESS=bar|plain|off overrides the choice. Written by hand: no
// Debian-packaged C++ library draws progress bars.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace relight {

class Progress {
 public:
  // `label` names the step ("render photos"); `total` is the number of work units.
  Progress(std::string label, int64_t total);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // Marks `n` more units done. Thread-safe and cheap (an atomic add; drawing is rate-limited).
  void Advance(int64_t n = 1);
  // Ends the step: clears the bar and logs the total time. Called by the destructor if needed.
  void Finish();
  // Units done so far.
  int64_t done() const { return done_.load(); }

  // "1m05s", "3.2s", "2h04m".
  static std::string FormatSeconds(double seconds);

 private:
  enum class Mode { kBar, kPlain, kOff };
  void Draw(int64_t done, bool final_draw);

  std::string label_;
  int64_t total_;
  Mode mode_;
  std::atomic<int64_t> done_{0};
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
  int last_decile_ = 0;
  bool bar_visible_ = false;
  bool finished_ = false;
  std::mutex mutex_;
};

}  // namespace relight
