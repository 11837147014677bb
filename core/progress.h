// Progress reporting on stderr for long loops.
//
//   Progress progress("render", frames.size());
//   parallel_for(...) { ...; progress.Advance(); }
//   progress.SetStatus("loss 0.12");
//   progress.Finish();  // also done by the destructor
//
// On a terminal: one line redrawn in place at most ~5 times a second,
//   render [#########...........] 45/100 45% 12.3 it/s ETA 0:05 loss 0.12
// Otherwise (CI, redirected output): one plain line per 10% step and one at
// the end, so logs stay short. RELIT_PROGRESS=0 silences progress output,
// RELIT_PROGRESS=1 forces the terminal style.
//
// Advance() and SetStatus() may be called from any thread. Only one bar is
// meant to be on screen at a time; spdlog messages written through
// InitLogging() clear the bar and redraw it below the message.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace relit {

// "M:SS" below an hour, "H:MM:SS" above, "--:--" for negative or non-finite.
std::string FormatDuration(double seconds);

// "12.3 it/s"; below one item per second "4.0 s/it"; "-- it/s" when unknown.
std::string FormatRate(double items_per_second);

// Renders one progress line. `total` <= 0 means unknown (no bar, percentage
// or ETA). `bar_width` 0 leaves out the bar. `finished` shows the total time
// ("in 0:08") instead of the ETA.
std::string FormatProgressLine(const std::string& label, int64_t done, int64_t total,
                               double elapsed_s, const std::string& status, int bar_width = 20,
                               bool finished = false);

class Progress {
 public:
  enum class Mode { kSilent, kPlain, kTty };

  // Mode from RELIT_PROGRESS, else kTty when stderr is a terminal, else kPlain.
  Progress(std::string label, int64_t total);
  Progress(std::string label, int64_t total, Mode mode);
  ~Progress();

  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void Advance(int64_t n = 1);
  // Free text shown after the counts, e.g. "loss 0.12".
  void SetStatus(std::string text);
  // Prints the final line; later calls and Advance() output are ignored.
  void Finish();

  int64_t done() const { return done_.load(std::memory_order_relaxed); }
  Mode mode() const { return mode_; }

  // The mode Progress(label, total) would pick.
  static Mode DefaultMode();

 private:
  double ElapsedSeconds() const;
  void MaybeDraw();
  // Draws the current state; mutex_ must be held.
  void DrawLocked(bool final_line);

  const std::string label_;
  const int64_t total_;
  const Mode mode_;
  const std::chrono::steady_clock::time_point start_;

  std::atomic<int64_t> done_{0};
  std::atomic<int64_t> next_draw_ns_{0};  // kTty: redraw not before this
  std::atomic<int> printed_decile_{0};    // kPlain: last 10% step printed

  std::mutex mutex_;  // guards the fields below and the drawing
  std::string status_;
  int64_t printed_done_ = -1;  // kPlain: `done` of the last printed line
  bool finished_ = false;
};

namespace internal {
// Serialises writes to stderr with the progress bar. While held, a bar on the
// terminal is cleared; it is redrawn when the lock is released. Used by the
// log sink installed by InitLogging().
class StderrLock {
 public:
  StderrLock();
  ~StderrLock();
  StderrLock(const StderrLock&) = delete;
  StderrLock& operator=(const StderrLock&) = delete;
};
}  // namespace internal

}  // namespace relit
