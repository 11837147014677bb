#include "core/shell.h"

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace relit {

std::string ShellQuote(const std::string& text) {
  std::string quoted = "'";
  for (char c : text) {
    if (c == '\'') quoted += "'\\''";
    else quoted += c;
  }
  return quoted + "'";
}

std::string ExitDescription(int status) {
  if (status == -1) return "could not be started";
  if (WIFEXITED(status)) {
    const int code = WEXITSTATUS(status);
    if (code == 127) return "not found (is it installed? tools/install-deps)";
    return "exited with status " + std::to_string(code);
  }
  if (WIFSIGNALED(status)) return "was killed by signal " + std::to_string(WTERMSIG(status));
  return "failed";
}

std::string CommandResult::ErrTail(size_t max_chars) const {
  if (err.size() <= max_chars) return err;
  return "[last " + std::to_string(max_chars) + " of " + std::to_string(err.size()) + " chars] " +
         err.substr(err.size() - max_chars);
}

CommandResult RunCommand(const std::string& command) {
  static std::atomic<int> counter{0};
  const std::filesystem::path log =
      std::filesystem::temp_directory_path() /
      ("relit-cmd-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ".log");
  // The group makes the redirection cover every part of a compound command.
  FILE* pipe = ::popen(("{ " + command + "\n} 2>" + ShellQuote(log.string())).c_str(), "r");
  RELIT_REQUIRE(pipe != nullptr, "cannot start a shell for: ", command.substr(0, command.find(' ')));
  CommandResult result;
  char buffer[1 << 16];
  size_t n;
  while ((n = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0) result.out.append(buffer, n);
  result.status = ::pclose(pipe);
  std::ifstream in(log, std::ios::binary);
  std::ostringstream err;
  err << in.rdbuf();
  result.err = err.str();
  std::error_code ignored;
  std::filesystem::remove(log, ignored);
  return result;
}

}  // namespace relit
