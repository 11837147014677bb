#include "core/main_wrapper.h"

#include <cstdio>
#include <cstdlib>
#include <exception>

#include <nlohmann/json.hpp>
#include <yaml-cpp/exceptions.h>

#include "core/error.h"
#include "core/log.h"
#include "core/progress.h"

namespace relit {

namespace internal {

int ReportFatalError(const std::string& message) {
  // One line: fold newlines and drop trailing whitespace.
  std::string line;
  for (char c : message) {
    if (c == '\n') {
      line += "; ";
    } else if (c != '\r') {
      line += c;
    }
  }
  while (!line.empty() && (line.back() == ' ' || line.back() == ';' || line.back() == '\t')) {
    line.pop_back();
  }
  line = "error: " + line;
  // Flush pending stdout first so the error comes after the output it
  // belongs to when both streams go to one terminal.
  std::fflush(stdout);
  {
    StderrLock lock;
    std::fprintf(stderr, "%s\n", line.c_str());
    std::fflush(stderr);
  }
  try {
    LogToFileOnly(spdlog::level::err, line);
  } catch (...) {
    // The message is already on stderr.
  }
  return 1;
}

}  // namespace internal

int RunMain(int argc, char** argv, const std::function<int(int, char**)>& run) {
  setenv("QT_QPA_PLATFORM", "offscreen", /*overwrite=*/0);
  try {
    if (!internal::LoggingInitialized()) InitLogging();
    return run(argc, argv);
  } catch (const Error& e) {
    return internal::ReportFatalError(e.what());
  } catch (const YAML::Exception& e) {
    return internal::ReportFatalError(std::string("YAML: ") + e.what());
  } catch (const nlohmann::json::exception& e) {
    return internal::ReportFatalError(std::string("JSON: ") + e.what());
  } catch (const std::exception& e) {
    return internal::ReportFatalError(std::string("unexpected: ") + e.what());
  } catch (...) {
    return internal::ReportFatalError("unexpected: unknown exception");
  }
}

}  // namespace relit
