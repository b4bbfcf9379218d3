#include "core/progress.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "core/log.h"

namespace relight {
namespace {
using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
}  // namespace

std::string Progress::FormatSeconds(double s) {
  char buf[64];
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 60) {
    std::snprintf(buf, sizeof(buf), "%.1fs", s);
  } else if (s < 3600) {
    std::snprintf(buf, sizeof(buf), "%dm%02ds", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  } else {
    std::snprintf(buf, sizeof(buf), "%dh%02dm", static_cast<int>(s) / 3600, (static_cast<int>(s) % 3600) / 60);
  }
  return buf;
}

Progress::Progress(std::string label, int64_t total)
    : label_(std::move(label)), total_(total > 0 ? total : 1), start_(Clock::now()), last_draw_(start_) {
  const char* env = std::getenv("RELIGHT_PROGRESS");
  const char* term = std::getenv("TERM");
  if (env != nullptr && std::strcmp(env, "off") == 0) {
    mode_ = Mode::kOff;
  } else if (env != nullptr && std::strcmp(env, "bar") == 0) {
    mode_ = Mode::kBar;
  } else if (env != nullptr && std::strcmp(env, "plain") == 0) {
    mode_ = Mode::kPlain;
  } else {
    const bool tty = ::isatty(STDERR_FILENO) && !(term != nullptr && std::strcmp(term, "dumb") == 0);
    mode_ = tty ? Mode::kBar : Mode::kPlain;
  }
}

Progress::~Progress() { Finish(); }

void Progress::Advance(int64_t n) {
  const int64_t done = done_.fetch_add(n) + n;
  if (mode_ == Mode::kOff) return;
  std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock() || finished_) return;
  Draw(done, false);
}

void Progress::Draw(int64_t done, bool final_draw) {
  const double elapsed = SecondsSince(start_);
  const double fraction = std::min(1.0, static_cast<double>(done) / static_cast<double>(total_));
  const double eta = fraction > 0 ? elapsed * (1.0 - fraction) / fraction : NAN;
  const int decile = static_cast<int>(fraction * 10.0);
  const bool decile_crossed = decile > last_decile_;
  if (decile_crossed) last_decile_ = decile;
  char line[256];
  std::snprintf(line, sizeof(line), "%s: %3d%% (%lld/%lld), %s elapsed, ETA %s", label_.c_str(),
                static_cast<int>(fraction * 100.0), static_cast<long long>(done), static_cast<long long>(total_),
                FormatSeconds(elapsed).c_str(), FormatSeconds(eta).c_str());
  if (mode_ == Mode::kBar) {
    if (decile_crossed) LogFileOnly(line);
    if (final_draw) return;
    if (elapsed < 1.0 || SecondsSince(last_draw_) < 0.1) return;
    last_draw_ = Clock::now();
    constexpr int kWidth = 28;
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(filled, '#');
    bar += std::string(kWidth - filled, '-');
    std::fprintf(stderr, "\r\033[K  %s [%s] %3d%% %lld/%lld  %s, ETA %s", label_.c_str(), bar.c_str(),
                 static_cast<int>(fraction * 100.0), static_cast<long long>(done),
                 static_cast<long long>(total_), FormatSeconds(elapsed).c_str(), FormatSeconds(eta).c_str());
    std::fflush(stderr);
    bar_visible_ = true;
  } else if (mode_ == Mode::kPlain && !final_draw && elapsed >= 2.0) {
    if (decile_crossed || SecondsSince(last_draw_) > 30.0) {
      last_draw_ = Clock::now();
      if (decile < 10) RLOG_INFO("{}", line);
    }
  }
}

void Progress::Finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (finished_) return;
  finished_ = true;
  if (mode_ == Mode::kOff) return;
  Draw(done_.load(), true);
  if (bar_visible_) {
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
  }
  const double elapsed = SecondsSince(start_);
  if (elapsed >= 1.0) {
    RLOG_INFO("{}: done {}/{} in {}", label_, static_cast<long long>(done_.load()), static_cast<long long>(total_),
              FormatSeconds(elapsed));
  }
}

}  // namespace relight
