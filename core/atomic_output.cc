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

}  // namespace

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

AtomicDir::AtomicDir(AtomicDir&& other) noexcept
    : target_(std::move(other.target_)),
      temp_(std::move(other.temp_)),
      committed_(other.committed_),
      active_(other.active_) {
  other.active_ = false;
}

AtomicDir::~AtomicDir() {
  if (!active_ || committed_) return;
  std::error_code ec;
  fs::remove_all(temp_, ec);
}

void AtomicDir::Commit() {
  RELIT_CHECK(active_ && !committed_);
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
