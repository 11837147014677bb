// The common main() of relit tools:
//
//   int main(int argc, char** argv) {
//     return relit::RunMain(argc, argv, [](int argc, char** argv) {
//       ...parse options, run the stage...
//       return 0;
//     });
//   }
//
// Errors surface as one "error: ..." line on stderr and exit code 1, so a
// shell pipeline or CI log shows the message, not a core dump from an
// uncaught exception.
#pragma once

#include <functional>
#include <string>

namespace relit {

// Runs `run` and returns its exit code. Before that, sets
// QT_QPA_PLATFORM=offscreen unless already set (OpenCV/VTK may pull in Qt,
// which aborts on machines without a display) and installs stderr logging
// if InitLogging() was not called yet. Exceptions are caught and printed:
//   relit::Error            -> "error: <message>"
//   YAML::Exception         -> "error: YAML: <what>"
//   nlohmann::json::exception -> "error: JSON: <what>"
//   anything else           -> "error: unexpected: <what>"
// each as a single line (newlines in messages are folded), returning 1.
int RunMain(int argc, char** argv, const std::function<int(int, char**)>& run);

namespace internal {
// Prints "error: <message>" as one line on stderr (and to the log file) and
// returns 1.
int ReportFatalError(const std::string& message);
}  // namespace internal

}  // namespace relit
