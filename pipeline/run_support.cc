#include "pipeline/run_support.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "core/error.h"
#include "core/shell.h"
#include "pipeline/executor.h"

namespace relit::pipeline {

namespace fs = std::filesystem;

namespace {

std::string LockPath(const std::string& workspace) {
  return (fs::path(workspace) / ".relit" / "run.lock").string();
}

std::vector<std::string> TailLines(const std::string& path, size_t max_bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  in.seekg(std::max<std::streamoff>(0, size - static_cast<std::streamoff>(max_bytes)));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<std::string> lines;
  std::string line;
  // '\r' ends a line too: a terminal-style progress bar redraws with it.
  for (char c : text) {
    if (c == '\n' || c == '\r') {
      if (!line.empty()) lines.push_back(line);
      line.clear();
    } else {
      line += c;
    }
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

}  // namespace

WorkspaceRunLock::WorkspaceRunLock(const std::string& workspace) {
  fs::create_directories(fs::path(workspace) / ".relit");
  const std::string path = LockPath(workspace);
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  RELIT_REQUIRE(fd_ >= 0, "cannot open ", path, ": ", std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    std::ifstream in(path);
    std::string holder;
    std::getline(in, holder);
    ::close(fd_);
    fd_ = -1;
    Fail("another relit run is using workspace ", workspace, " (", holder.empty() ? "?" : holder,
         "); wait for it or stop it first");
  }
  char host[256] = {0};
  ::gethostname(host, sizeof(host) - 1);
  const std::string holder = "pid " + std::to_string(::getpid()) + " on " + host + "\n";
  if (::ftruncate(fd_, 0) == 0 && ::write(fd_, holder.data(), holder.size()) < 0) {
    // Only informative.
  }
}

WorkspaceRunLock::~WorkspaceRunLock() {
  if (fd_ >= 0) ::close(fd_);  // closing releases the flock
}

bool WorkspaceRunLock::IsHeld(const std::string& workspace) {
  const std::string path = LockPath(workspace);
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool held = ::flock(fd, LOCK_SH | LOCK_NB) != 0;
  ::close(fd);
  return held;
}

std::string LogTail(const std::string& path, int lines) {
  std::vector<std::string> all = TailLines(path, 16384);
  const size_t first = all.size() > static_cast<size_t>(lines) ? all.size() - lines : 0;
  std::string text;
  for (size_t i = first; i < all.size(); ++i) text += all[i] + "\n";
  return text;
}

std::string LastLogLine(const std::string& path) {
  std::vector<std::string> all = TailLines(path, 4096);
  for (auto it = all.rbegin(); it != all.rend(); ++it) {
    if (it->rfind("=== relit", 0) == 0) continue;
    std::string line = *it;
    if (line.size() > 100) line = line.substr(0, 97) + "...";
    return line;
  }
  return "";
}

std::string Indent(const std::string& text, const std::string& prefix) {
  std::istringstream in(text);
  std::string result;
  for (std::string line; std::getline(in, line);) result += prefix + line + "\n";
  if (!result.empty()) result.pop_back();
  return result;
}

bool RelightHasSubcommand(const ToolLocator& tools, const std::string& name) {
  const std::string relight = tools.Find("relight");
  if (relight.empty()) return false;
  // `relit-relight export --help` is not a test: CLI11 prints the main help
  // for an unknown word followed by --help. Look for the subcommand in the
  // list the main help prints instead ("Subcommands:" then "  export  ...").
  std::string out;
  if (RunCapture(ShellQuote(relight) + " --help </dev/null", &out) != 0) return false;
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  const size_t list = out.find("subcommands:");
  if (list == std::string::npos) return false;
  std::istringstream lines(out.substr(list));
  for (std::string line; std::getline(lines, line);) {
    std::istringstream words(line);
    std::string first;
    if (line.size() > 1 && std::isspace(static_cast<unsigned char>(line[0])) && (words >> first) &&
        first == name) {
      return true;
    }
  }
  return false;
}

bool WithExport(const PipelineConfig& config, const ToolLocator& tools) {
  if (config.export_mode != "auto") return config.export_mode == "on";
  return RelightHasSubcommand(tools, "export");
}

bool WithAugment(const PipelineConfig& config, const ToolLocator& tools) {
  // Looked up by iteration: operator[] on a missing key of a const node throws.
  auto child = [](const YAML::Node& node, const std::string& key) {
    if (node.IsMap()) {
      for (const auto& entry : node) {
        if (entry.first.as<std::string>() == key) return entry.second;
      }
    }
    return YAML::Node();
  };
  const YAML::Node enabled = child(child(config.relight, "augment"), "enabled");
  if (enabled.IsDefined() && !enabled.IsNull() && !enabled.as<bool>()) return false;
  return RelightHasSubcommand(tools, "augment");
}

}  // namespace relit::pipeline
