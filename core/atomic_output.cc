#include "core/atomic_output.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <system_error>
#include <utility>

#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/error.h"

namespace relit {

namespace fs = std::filesystem;

namespace {

// Normalises "out/dir/" to "out/dir" so the name used for temporaries is
// never empty.
fs::path NormalizeTarget(fs::path target) {
  target = target.lexically_normal();
  if (!target.has_filename() && target.has_parent_path()) target = target.parent_path();
  const std::string name = target.filename().string();
  RELIT_REQUIRE(!name.empty() && name != "." && name != "..",
                "cannot use '", target.string(), "' as an output path: it needs a name");
  return target;
}

fs::path ParentOf(const fs::path& target) {
  return target.has_parent_path() ? target.parent_path() : fs::path(".");
}

void CreateParent(const fs::path& target) {
  std::error_code ec;
  fs::create_directories(ParentOf(target), ec);
  RELIT_REQUIRE(!ec, "cannot create directory ", ParentOf(target).string(), " for ",
                target.string(), ": ", ec.message());
}

fs::path Sibling(const fs::path& target, const std::string& tag, const std::string& suffix = "") {
  return ParentOf(target) /
         ("." + target.filename().string() + "." + tag + "-" + std::to_string(getpid()) + suffix);
}

// True when `pid` names a running process other than us. EPERM means it
// exists but belongs to someone else, which still counts as running.
bool OtherProcessRunning(long pid) {
  if (pid <= 0 || pid == static_cast<long>(getpid())) return false;
  return kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
}

// weakly_canonical of an absolute path; the lexical form when that fails.
fs::path Canonical(const fs::path& path) {
  std::error_code ec;
  const fs::path absolute = fs::absolute(path, ec);
  if (ec) return path.lexically_normal();
  fs::path canonical = fs::weakly_canonical(absolute, ec);
  if (ec) return absolute.lexically_normal();
  return canonical;
}

// True when `inner` is `outer` or lies below it (both canonical).
bool IsWithin(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin();
  for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
    if (o->empty()) continue;  // a trailing separator
    if (i == inner.end() || *i != *o) return false;
  }
  return true;
}

std::string ReadSmallFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The stage recorded in `dir`: its marker file, else the "tool" of its
// run.json (outputs written before the marker existed); "" when neither.
std::string RecordedStage(const fs::path& dir) {
  std::error_code ec;
  const fs::path marker = dir / kOutputMarkerFile;
  if (fs::is_regular_file(marker, ec)) {
    std::string text = ReadSmallFile(marker);
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
    return text;
  }
  const fs::path record = dir / "run.json";
  if (fs::is_regular_file(record, ec) && fs::file_size(record, ec) < (1u << 20)) {
    const nlohmann::json json = nlohmann::json::parse(ReadSmallFile(record), nullptr, false);
    if (json.is_object() && json.contains("tool") && json["tool"].is_string()) {
      return json["tool"].get<std::string>();
    }
  }
  return "";
}

}  // namespace

void CheckOutputReplaceable(const fs::path& target, const OutputGuard& guard,
                            const std::string& option) {
  const std::string name = target.string();
  const fs::path canonical_target = Canonical(target);
  for (const fs::path& input : guard.inputs) {
    if (input.empty()) continue;
    const fs::path canonical_input = Canonical(input);
    RELIT_REQUIRE(!IsWithin(canonical_input, canonical_target), option, " ", name,
                  " holds the input ", input.string(), ": ", guard.stage,
                  " replaces its output folder as a whole, so choose a new or empty folder for ",
                  option, " (e.g. ", (target / guard.stage.substr(guard.stage.find_last_of("- ") + 1)).string(),
                  ")");
  }
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(target, ec);
  if (status.type() == fs::file_type::not_found) return;
  RELIT_REQUIRE(status.type() != fs::file_type::regular, option, " ", name,
                " is an existing file, not a folder: ", guard.stage,
                " never replaces a file; give a folder path");
  RELIT_REQUIRE(status.type() == fs::file_type::directory, option, " ", name,
                " exists and is not a folder (a link or special file): give a new folder path");
  fs::directory_iterator entries(target, ec);
  RELIT_REQUIRE(!ec, "cannot read the output folder ", name, ": ", ec.message());
  if (entries == fs::directory_iterator()) return;  // empty
  const std::string recorded = RecordedStage(target);
  if (!recorded.empty() && recorded == guard.stage) return;
  if (guard.force) return;
  if (!recorded.empty()) {
    Fail(option, " ", name, " was written by ", recorded, ", not ", guard.stage,
         ": choose another folder, or pass --force to replace it");
  }
  Fail(option, " ", name, " is a folder with files that ", guard.stage,
       " did not write (no ", kOutputMarkerFile,
       " marker): choose a new or empty folder, or pass --force to replace it and everything in it");
}

namespace internal {

void RemoveStaleTemporaries(const fs::path& target) {
  const std::string name = target.filename().string();
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(ParentOf(target), ec)) {
    const std::string entry_name = entry.path().filename().string();
    for (const char* tag : {".tmp-", ".old-"}) {
      const std::string prefix = "." + name + tag;
      if (entry_name.compare(0, prefix.size(), prefix) != 0) continue;
      // The pid is the leading digits after the prefix (files may carry a
      // further "-<n>" counter).
      const std::string rest = entry_name.substr(prefix.size());
      size_t digits = 0;
      while (digits < rest.size() && std::isdigit(static_cast<unsigned char>(rest[digits]))) {
        ++digits;
      }
      if (digits == 0 || digits > 9) continue;
      if (digits < rest.size() && rest[digits] != '-') continue;
      if (OtherProcessRunning(std::stol(rest.substr(0, digits)))) continue;
      std::error_code remove_ec;
      fs::remove_all(entry.path(), remove_ec);
    }
  }
}

}  // namespace internal

void AtomicWriteFile(const fs::path& path, const std::string& content) {
  const fs::path target = NormalizeTarget(path);
  CreateParent(target);
  // The counter keeps concurrent writers of one path in this process apart.
  static std::atomic<int> counter{0};
  const fs::path temp = Sibling(target, "tmp", "-" + std::to_string(counter++));

  FILE* file = std::fopen(temp.c_str(), "wb");
  RELIT_REQUIRE(file != nullptr, "cannot write ", target.string(), ": ", std::strerror(errno));
  const bool written = std::fwrite(content.data(), 1, content.size(), file) == content.size();
  const int write_errno = errno;
  const bool closed = std::fclose(file) == 0;
  if (!written || !closed) {
    const int saved = written ? errno : write_errno;
    std::error_code ec;
    fs::remove(temp, ec);
    Fail("cannot write ", target.string(), ": ", std::strerror(saved));
  }
  std::error_code ec;
  fs::rename(temp, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    Fail("cannot write ", target.string(), ": rename failed: ", ec.message());
  }
}

AtomicDir::AtomicDir(fs::path target) : target_(NormalizeTarget(std::move(target))) {
  CreateParent(target_);
  internal::RemoveStaleTemporaries(target_);
  temp_ = Sibling(target_, "tmp");
  std::error_code ec;
  fs::remove_all(temp_, ec);
  fs::create_directory(temp_, ec);
  RELIT_REQUIRE(!ec, "cannot create temporary directory ", temp_.string(), " for ",
                target_.string(), ": ", ec.message());
}

AtomicDir::AtomicDir(fs::path target, OutputGuard guard, std::string option)
    : AtomicDir((CheckOutputReplaceable(target, guard, option), target)) {
  guarded_ = true;
  guard_ = std::move(guard);
  option_ = std::move(option);
  AtomicWriteFile(temp_ / kOutputMarkerFile, guard_.stage + "\n");
}

AtomicDir::AtomicDir(AtomicDir&& other) noexcept
    : target_(std::move(other.target_)),
      temp_(std::move(other.temp_)),
      committed_(other.committed_),
      active_(other.active_),
      guarded_(other.guarded_),
      guard_(std::move(other.guard_)),
      option_(std::move(other.option_)) {
  other.active_ = false;
}

AtomicDir::~AtomicDir() {
  if (!active_ || committed_) return;
  std::error_code ec;
  fs::remove_all(temp_, ec);
}

void AtomicDir::Commit() {
  RELIT_CHECK(active_ && !committed_);
  // The folder may have changed while the stage ran.
  if (guarded_) CheckOutputReplaceable(target_, guard_, option_);
  std::error_code ec;
  const fs::path old = Sibling(target_, "old");
  const bool had_target = fs::symlink_status(target_, ec).type() != fs::file_type::not_found;
  if (had_target) {
    fs::remove_all(old, ec);
    fs::rename(target_, old, ec);
    RELIT_REQUIRE(!ec, "cannot replace ", target_.string(), ": moving the old output away failed: ",
                  ec.message());
  }
  fs::rename(temp_, target_, ec);
  if (ec) {
    // Put the previous output back so a failed commit changes nothing.
    const std::string message = ec.message();
    if (had_target) fs::rename(old, target_, ec);
    Fail("cannot replace ", target_.string(), " with ", temp_.string(), ": ", message);
  }
  committed_ = true;
  // A failure here only leaves a stale ".old-<pid>" that the next run removes.
  if (had_target) fs::remove_all(old, ec);
}

}  // namespace relit
