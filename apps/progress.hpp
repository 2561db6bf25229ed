// Progress of a long command on stderr, shared by the cosserat tool's commands: a bar redrawn in
// place when stderr is a terminal; otherwise (a log file, a pipe) a line every 10 s of wall time
// once the command has run for 10 s, so that short runs print nothing.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

namespace cosserat::cli {

class Progress {
 public:
  // `count`: the name of what is counted ("frame": shows "frame k/total"; empty: only the percentage).
  Progress(std::string label, long total, std::string count = "")
      : label_(std::move(label)), count_(std::move(count)), total_(std::max(total, 1L)), tty_(isatty(STDERR_FILENO)),
        start_(Clock::now()), next_line_(kLineInterval) {}
  ~Progress() { clear(); }
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // `done` of the total, at simulated time t [s].
  void update(long done, double t) {
    const int pct = static_cast<int>(100 * done / total_);
    if (tty_) {
      if (pct == shown_) return;
      shown_ = pct;
      const int w = 30, filled = w * pct / 100;
      // (the wall time left on the bar too: outside probe CL)
      const double wall = std::chrono::duration<double>(Clock::now() - start_).count();
      const double left = done > 0 ? wall * static_cast<double>(total_ - done) / static_cast<double>(done) : 0.0;
      std::fprintf(stderr, "\r%s [%.*s%*s] %3d%%%s  t = %.3f s, about %.0f s left ", label_.c_str(), filled,
                   "##############################", w - filled, "", pct, counted(done).c_str(), t, left);
      std::fflush(stderr);
      return;
    }
    // the clock read every 64 updates where they come fast (a run's steps), at each where they come
    // more than 1 ms apart (render's frames: outside probe CL, a 3000-frame render's first pass was
    // silent for 15-18 s at every 64th)
    if (++since_read_ < stride_ && done != total_) return;
    since_read_ = 0;
    const double wall = std::chrono::duration<double>(Clock::now() - start_).count();
    stride_ = wall - last_read_ > 1e-3 * stride_ ? 1 : 64;
    last_read_ = wall;
    if (wall < next_line_) return;
    next_line_ = wall + kLineInterval;
    const double left = done > 0 ? wall * static_cast<double>(total_ - done) / static_cast<double>(done) : 0.0;
    std::fprintf(stderr, "%s: %d%%%s, t = %.4g s, %.0f s wall, about %.0f s left\n", label_.c_str(), pct,
                 counted(done).c_str(), t, wall, left);
    std::fflush(stderr);
  }
  // A phase without a known end (an iteration): `text` says where it is; the same redrawing on a
  // terminal, and the same line every 10 s of wall time otherwise.
  void note(const std::string& text) {
    const double wall = std::chrono::duration<double>(Clock::now() - start_).count();
    if (tty_) {
      std::fprintf(stderr, "\r%s: %-70.70s", label_.c_str(), text.c_str());
      std::fflush(stderr);
      shown_ = 0;
      return;
    }
    if (wall < next_line_) return;
    next_line_ = wall + kLineInterval;
    std::fprintf(stderr, "%s: %s, %.0f s wall\n", label_.c_str(), text.c_str(), wall);
    std::fflush(stderr);
  }
  // Erases the bar (before other output).
  void clear() {
    if (tty_ && shown_ >= 0) std::fprintf(stderr, "\r%*s\r", 80, "");
    shown_ = -1;
  }

 private:
  using Clock = std::chrono::steady_clock;
  static constexpr double kLineInterval = 10.0;  // [s]
  std::string counted(long done) const {
    return count_.empty() ? std::string() : "  " + count_ + " " + std::to_string(done) + "/" + std::to_string(total_);
  }
  std::string label_, count_;
  long total_;
  bool tty_;
  Clock::time_point start_;
  double next_line_;
  int shown_ = -1;
  long since_read_ = 0, stride_ = 1;  // updates since the clock was read, and how many between reads
  double last_read_ = 0.0;
};

}  // namespace cosserat::cli
