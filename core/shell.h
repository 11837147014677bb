// Running external tools (ffmpeg, COLMAP, Blender) through the shell.
#pragma once

#include <string>

namespace relit {

// Quotes one argument for /bin/sh: wraps it in single quotes and escapes
// embedded single quotes, so paths with spaces or quotes pass unchanged.
std::string ShellQuote(const std::string& text);

}  // namespace relit
