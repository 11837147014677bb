// Atomic outputs: a stage either leaves its previous output untouched or
// replaces it completely, so an interrupted run never leaves a half-written
// file or directory for the next stage to trip over.
//
//   AtomicDir out("work/frames");          // writes go to work/.frames.tmp-<pid>
//   WriteImage((out.path() / "0001.exr").string(), image);
//   out.Commit();                          // work/frames now holds the new set
//
// Nothing here calls fsync: the goal is consistency after a crash or Ctrl-C,
// not durability across power loss.
#pragma once

#include <filesystem>
#include <string>

namespace relit {

// Writes `content` to a temporary file next to `path` and renames it over
// `path`. Creates parent directories. Throws relit::Error naming the file.
void AtomicWriteFile(const std::filesystem::path& path, const std::string& content);

// A directory that only appears at `target` when Commit() is called.
class AtomicDir {
 public:
  // Creates the temporary directory ".<name>.tmp-<pid>" next to `target`
  // (parents are created). Leftovers of earlier runs that crashed (same name
  // pattern, owning process gone) are removed first.
  explicit AtomicDir(std::filesystem::path target);
  // Removes the temporary directory unless Commit() succeeded.
  ~AtomicDir();

  AtomicDir(const AtomicDir&) = delete;
  AtomicDir& operator=(const AtomicDir&) = delete;
  AtomicDir(AtomicDir&& other) noexcept;
  AtomicDir& operator=(AtomicDir&&) = delete;

  // Where to write; valid until Commit().
  const std::filesystem::path& path() const { return temp_; }
  const std::filesystem::path& target() const { return target_; }
  bool committed() const { return committed_; }

  // Replaces `target` (file or directory, if any) with the temporary
  // directory: the old target is renamed away, the new one renamed in, then
  // the old one deleted. Readers see either the old or the new tree.
  void Commit();

 private:
  std::filesystem::path target_;
  std::filesystem::path temp_;
  bool committed_ = false;
  bool active_ = true;  // false once moved from
};

namespace internal {
// Removes ".<name>.tmp-<pid>" and ".<name>.old-<pid>" entries next to
// `target` whose process no longer runs (or is this process). Exposed for
// tests.
void RemoveStaleTemporaries(const std::filesystem::path& target);
}  // namespace internal

}  // namespace relit
