// Logging setup. After InitLogging(), log with spdlog directly:
//
//   spdlog::info("rendered {} frames in {:.1f} s", n, seconds);
//   spdlog::debug("...");   // shown with --verbose / level debug
//
// Messages go to stderr (stdout stays free for a tool's real output), in
// colour only when stderr is a terminal, and optionally to a log file. The
// stderr sink cooperates with Progress: a bar on the terminal is cleared
// before a message and redrawn after it.
#pragma once

#include <string>
#include <vector>

#include <spdlog/spdlog.h>

namespace relit {

// Installs the default spdlog logger. `log_file` (if not empty) receives the
// same messages with full timestamps; its directory is created and the file
// is appended to. May be called again to change the file or level. Throws
// relit::Error when the log file cannot be opened.
void InitLogging(const std::string& log_file = "",
                 spdlog::level::level_enum level = spdlog::level::info);

// Logs to `log_file` (and stderr) until the scope ends, then to stderr only,
// so a stage's log file is closed before its output folder is moved into
// place or deleted, whether the run ends normally or by an exception.
class LogFileScope {
 public:
  LogFileScope(const std::string& log_file, spdlog::level::level_enum level);
  ~LogFileScope();
  LogFileScope(const LogFileScope&) = delete;
  LogFileScope& operator=(const LogFileScope&) = delete;

 private:
  spdlog::level::level_enum level_;
};

// Changes the level of the logger and of all its outputs.
void SetVerbosity(spdlog::level::level_enum level);

// "trace", "debug", "info", "warn", "error" or "off"; relit::Error otherwise.
spdlog::level::level_enum ParseLogLevel(const std::string& name);
// The names ParseLogLevel knows, for option tables.
std::vector<std::string> LogLevelNames();

namespace internal {
// True once InitLogging() has run.
bool LoggingInitialized();
// Writes `message` to the log file only (no-op without one); the main wrapper
// uses it so a fatal error printed on stderr also ends up in the file.
void LogToFileOnly(spdlog::level::level_enum level, const std::string& message);
}  // namespace internal

}  // namespace relit
