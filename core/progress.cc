#include "core/progress.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "core/run_record.h"

namespace relit {

namespace {

constexpr int64_t kRedrawIntervalNs = 200'000'000;  // ~5 redraws per second

// What is on the terminal's last line. Leaked on purpose so progress bars or
// log lines written during static destruction still find it.
struct TerminalLine {
  std::mutex mutex;
  std::string bar;  // the bar currently shown (without "\r"), "" when none
};

TerminalLine& Terminal() {
  static TerminalLine* line = new TerminalLine;
  return *line;
}

void WriteStderr(const std::string& text) {
  std::fwrite(text.data(), 1, text.size(), stderr);
  std::fflush(stderr);
}

// Terminal width, 0 when unknown. A bar wider than the terminal would wrap
// and "\r" would then only redraw its last part.
size_t TerminalColumns() {
  winsize size{};
  if (ioctl(STDERR_FILENO, TIOCGWINSZ, &size) == 0 && size.ws_col > 0) return size.ws_col;
  return 0;
}

std::string FitToTerminal(std::string line) {
  const size_t columns = TerminalColumns();
  if (columns == 0 || line.size() < columns) return line;
  size_t cut = columns - 1;
  // Do not split a UTF-8 sequence.
  while (cut > 0 && (static_cast<unsigned char>(line[cut]) & 0xC0) == 0x80) --cut;
  line.resize(cut);
  return line;
}

std::string OneDecimal(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), value >= 100 ? "%.0f" : "%.1f", value);
  return buffer;
}

}  // namespace

std::string FormatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  const long long total = std::llround(seconds);
  const long long h = total / 3600, m = (total / 60) % 60, s = total % 60;
  char buffer[48];
  if (h > 0) {
    std::snprintf(buffer, sizeof(buffer), "%lld:%02lld:%02lld", h, m, s);
  } else {
    std::snprintf(buffer, sizeof(buffer), "%lld:%02lld", m, s);
  }
  return buffer;
}

std::string FormatRate(double items_per_second) {
  if (!std::isfinite(items_per_second) || items_per_second <= 0) return "-- it/s";
  if (items_per_second < 1.0) return OneDecimal(1.0 / items_per_second) + " s/it";
  return OneDecimal(items_per_second) + " it/s";
}

std::string FormatProgressLine(const std::string& label, int64_t done, int64_t total,
                               double elapsed_s, const std::string& status, int bar_width,
                               bool finished) {
  std::string line = label;
  const double rate = (done > 0 && elapsed_s > 0) ? done / elapsed_s : 0.0;
  if (total > 0) {
    const double fraction = std::clamp(static_cast<double>(done) / total, 0.0, 1.0);
    if (bar_width > 0) {
      const int filled = static_cast<int>(std::floor(fraction * bar_width));
      line += " [" + std::string(filled, '#') + std::string(bar_width - filled, '.') + "]";
    }
    line += " " + std::to_string(done) + "/" + std::to_string(total) + " " +
            std::to_string(static_cast<int>(std::floor(fraction * 100))) + "%";
    line += " " + FormatRate(rate);
    if (finished) {
      line += " in " + FormatDuration(elapsed_s);
    } else {
      const double eta = rate > 0 ? std::max<double>(0, total - done) / rate : -1;
      line += " ETA " + FormatDuration(eta);
    }
  } else {
    line += " " + std::to_string(done) + " " + FormatRate(rate);
    line += (finished ? " in " : " elapsed ") + FormatDuration(elapsed_s);
  }
  if (!status.empty()) line += " " + status;
  return line;
}

Progress::Mode Progress::DefaultMode() {
  if (const char* env = std::getenv("RELIT_PROGRESS")) {
    if (std::strcmp(env, "0") == 0) return Mode::kSilent;
    if (std::strcmp(env, "1") == 0) return Mode::kTty;
  }
  return isatty(STDERR_FILENO) ? Mode::kTty : Mode::kPlain;
}

Progress::Progress(std::string label, int64_t total)
    : Progress(std::move(label), total, DefaultMode()) {}

Progress::Progress(std::string label, int64_t total, Mode mode)
    : label_(std::move(label)), total_(total), mode_(mode),
      start_(std::chrono::steady_clock::now()) {
  if (mode_ == Mode::kTty) {
    std::lock_guard<std::mutex> lock(mutex_);
    DrawLocked(false);
    next_draw_ns_ = kRedrawIntervalNs;
  }
}

Progress::~Progress() {
  try {
    Finish();
  } catch (...) {
    // Destructors must not throw; losing the last progress line is harmless.
  }
}

double Progress::ElapsedSeconds() const {
  return SecondsSince(start_);
}

void Progress::Advance(int64_t n) {
  done_.fetch_add(n, std::memory_order_relaxed);
  MaybeDraw();
}

void Progress::SetStatus(std::string text) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status_ = std::move(text);
  }
  MaybeDraw();
}

void Progress::MaybeDraw() {
  if (mode_ == Mode::kTty) {
    // Cheap check first; the compare-exchange lets one thread draw per period.
    const int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                            std::chrono::steady_clock::now() - start_).count();
    int64_t next = next_draw_ns_.load(std::memory_order_relaxed);
    if (now < next) return;
    if (!next_draw_ns_.compare_exchange_strong(next, now + kRedrawIntervalNs)) return;
  } else if (mode_ == Mode::kPlain) {
    if (total_ <= 0) return;
    const int decile = static_cast<int>(std::min<int64_t>(10, done() * 10 / total_));
    int printed = printed_decile_.load(std::memory_order_relaxed);
    do {
      if (decile <= printed) return;
    } while (!printed_decile_.compare_exchange_weak(printed, decile));
  } else {
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!finished_) DrawLocked(false);
}

void Progress::Finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (finished_) return;
  finished_ = true;
  DrawLocked(true);
}

void Progress::DrawLocked(bool final_line) {
  const int64_t done = this->done();
  const double elapsed = ElapsedSeconds();
  if (mode_ == Mode::kTty) {
    const std::string line =
        FitToTerminal(FormatProgressLine(label_, done, total_, elapsed, status_, 20, final_line));
    TerminalLine& terminal = Terminal();
    std::lock_guard<std::mutex> lock(terminal.mutex);
    // "\033[K" clears what a longer previous line left behind.
    WriteStderr("\r" + line + "\033[K" + (final_line ? "\n" : ""));
    terminal.bar = final_line ? "" : line;
  } else if (mode_ == Mode::kPlain) {
    const bool complete = final_line || (total_ > 0 && done >= total_);
    // The 100% line already reads as a final line; do not repeat it.
    if (final_line && done == printed_done_ && total_ > 0 && done >= total_) return;
    const std::string line = FormatProgressLine(label_, done, total_, elapsed, status_, 0, complete);
    TerminalLine& terminal = Terminal();
    std::lock_guard<std::mutex> lock(terminal.mutex);
    WriteStderr(line + "\n");
    printed_done_ = done;
  }
}

namespace internal {

StderrLock::StderrLock() {
  TerminalLine& terminal = Terminal();
  terminal.mutex.lock();
  if (!terminal.bar.empty()) WriteStderr("\r\033[K");
}

StderrLock::~StderrLock() {
  TerminalLine& terminal = Terminal();
  if (!terminal.bar.empty()) WriteStderr("\r" + terminal.bar + "\033[K");
  terminal.mutex.unlock();
}

}  // namespace internal

}  // namespace relit
