// Running external tools (ffmpeg, COLMAP, Blender) through the shell.
#pragma once

#include <string>

namespace relit {

// Quotes one argument for /bin/sh: wraps it in single quotes and escapes
// embedded single quotes, so paths with spaces or quotes pass unchanged.
std::string ShellQuote(const std::string& text);

struct CommandResult {
  std::string out;    // everything the command wrote to stdout
  std::string err;    // the last ~4 KiB of its stderr
  int status = 0;     // as returned by pclose (see ExitDescription)
  bool ok() const { return status == 0; }
};

// Runs `command` with /bin/sh, collecting stdout and the tail of stderr.
// Never throws for a failing command; check ok().
CommandResult RunCommand(const std::string& command);

// "exited with status 2", "not found (is it installed? tools/install-deps)",
// "was killed by signal 9", ... for a pclose/system status.
std::string ExitDescription(int status);

}  // namespace relit
