#include "core/log.h"

#include <filesystem>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>

#include "core/error.h"
#include "core/progress.h"

namespace relit {

namespace {

// Wraps the stderr sink so that messages and a terminal progress bar take
// turns on the last line instead of being glued together.
class ProgressAwareSink : public spdlog::sinks::sink {
 public:
  explicit ProgressAwareSink(std::shared_ptr<spdlog::sinks::sink> inner)
      : inner_(std::move(inner)) {}

  void log(const spdlog::details::log_msg& msg) override {
    internal::StderrLock lock;
    inner_->log(msg);
  }
  void flush() override { inner_->flush(); }
  void set_pattern(const std::string& pattern) override { inner_->set_pattern(pattern); }
  void set_formatter(std::unique_ptr<spdlog::formatter> formatter) override {
    inner_->set_formatter(std::move(formatter));
  }

 private:
  std::shared_ptr<spdlog::sinks::sink> inner_;
};

struct LogState {
  std::mutex mutex;
  bool initialized = false;
  std::shared_ptr<spdlog::sinks::sink> file_sink;  // null without a log file
};

LogState& State() {
  static LogState* state = new LogState;  // leaked: used until process exit
  return *state;
}

}  // namespace

void InitLogging(const std::string& log_file, spdlog::level::level_enum level) {
  std::vector<spdlog::sink_ptr> sinks;
  auto stderr_sink = std::make_shared<ProgressAwareSink>(
      std::make_shared<spdlog::sinks::stderr_color_sink_mt>(spdlog::color_mode::automatic));
  stderr_sink->set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
  stderr_sink->set_level(level);
  sinks.push_back(stderr_sink);

  std::shared_ptr<spdlog::sinks::sink> file_sink;
  if (!log_file.empty()) {
    const std::filesystem::path path(log_file);
    std::error_code ec;
    if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
    RELIT_REQUIRE(!ec, "cannot create directory for log file ", log_file, ": ", ec.message());
    try {
      file_sink = std::make_shared<spdlog::sinks::basic_file_sink_mt>(log_file, /*truncate=*/false);
    } catch (const spdlog::spdlog_ex& e) {
      Fail("cannot open log file ", log_file, ": ", e.what());
    }
    file_sink->set_pattern("[%Y-%m-%d %H:%M:%S.%e] [%l] [%t] %v");
    file_sink->set_level(level);
    sinks.push_back(file_sink);
  }

  auto logger = std::make_shared<spdlog::logger>("relit", sinks.begin(), sinks.end());
  logger->set_level(level);
  // Flushing every message keeps the file complete when a run crashes; relit
  // logs per stage and per frame, not per pixel, so the cost is negligible.
  logger->flush_on(spdlog::level::trace);
  spdlog::set_default_logger(logger);

  LogState& state = State();
  std::lock_guard<std::mutex> lock(state.mutex);
  state.initialized = true;
  state.file_sink = file_sink;
}

LogFileScope::LogFileScope(const std::string& log_file, spdlog::level::level_enum level) : level_(level) {
  try {
    InitLogging(log_file, level);
  } catch (...) {
    InitLogging("", level);
    throw;
  }
}

LogFileScope::~LogFileScope() { InitLogging("", level_); }

void SetVerbosity(spdlog::level::level_enum level) {
  const std::shared_ptr<spdlog::logger> logger = spdlog::default_logger();
  logger->set_level(level);
  for (const spdlog::sink_ptr& sink : logger->sinks()) sink->set_level(level);
}

spdlog::level::level_enum ParseLogLevel(const std::string& name) {
  using spdlog::level::level_enum;
  static const std::pair<const char*, level_enum> kLevels[] = {
      {"trace", level_enum::trace}, {"debug", level_enum::debug}, {"info", level_enum::info},
      {"warn", level_enum::warn},   {"error", level_enum::err},   {"off", level_enum::off}};
  for (const auto& [text, level] : kLevels) {
    if (name == text) return level;
  }
  Fail("unknown log level '", name, "' (use trace, debug, info, warn, error or off)");
}

std::vector<std::string> LogLevelNames() { return {"trace", "debug", "info", "warn", "error", "off"}; }

namespace internal {

bool LoggingInitialized() {
  LogState& state = State();
  std::lock_guard<std::mutex> lock(state.mutex);
  return state.initialized;
}

void LogToFileOnly(spdlog::level::level_enum level, const std::string& message) {
  LogState& state = State();
  std::lock_guard<std::mutex> lock(state.mutex);
  if (!state.file_sink) return;
  state.file_sink->log(spdlog::details::log_msg("relit", level, message));
  state.file_sink->flush();
}

}  // namespace internal

}  // namespace relit
