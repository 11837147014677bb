// Running external tools (ffmpeg, COLMAP, Blender) through the shell.
#pragma once

#include <string>

namespace relit {

// Quotes one argument for /bin/sh: wraps it in single quotes and escapes
// embedded single quotes, so paths with spaces or quotes pass unchanged.
std::string ShellQuote(const std::string& text);

struct CommandResult {
  std::string out;    // everything the command wrote to stdout
  std::string err;    // everything the command wrote to stderr (never truncated)
  int status = 0;     // as returned by pclose (see ExitDescription)
  bool ok() const { return status == 0; }
  // The end of `err` for a human-readable message: at most `max_chars`
  // characters, starting with "[last N of M chars] " when it was cut.
  // Never parse this; parse `err` or `out`.
  std::string ErrTail(size_t max_chars = 4096) const;
};

// Runs `command` with /bin/sh, collecting all of its stdout and stderr.
// Never throws for a failing command; check ok().
CommandResult RunCommand(const std::string& command);

// "exited with status 2", "not found (is it installed? tools/install-deps)",
// "was killed by signal 9", ... for a pclose/system status.
std::string ExitDescription(int status);

}  // namespace relit
