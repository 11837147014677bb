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
#include <vector>

namespace relit {

// The file a stage writes into every output folder it creates; its content
// is the stage's name. A folder holding it (with the same name) may be
// replaced by that stage on the next run.
inline constexpr const char* kOutputMarkerFile = ".relit-output";

// Who may replace an existing output folder (docs/refusals.md):
//   - a regular file, a symbolic link or other non-folder: never;
//   - a folder that holds (or is) one of `inputs`: never, not even with force;
//   - an empty folder, or one with the marker of `stage` (or, for outputs
//     written before the marker existed, a run.json whose "tool" is `stage`):
//     yes;
//   - any other folder: only with `force` (the stage's --force flag).
struct OutputGuard {
  std::string stage;                          // "relit-capture"
  bool force = false;
  std::vector<std::filesystem::path> inputs;  // files/folders the stage reads
};

// Throws relit::Error naming `target` and saying what to do when the rule
// above forbids replacing it. `option` names the flag that chose the path
// ("--out", "--workspace") for the message.
void CheckOutputReplaceable(const std::filesystem::path& target, const OutputGuard& guard,
                            const std::string& option = "--out");

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
  // The same, after CheckOutputReplaceable(target, guard); the marker file is
  // written into the new folder and the check is repeated by Commit().
  AtomicDir(std::filesystem::path target, OutputGuard guard, std::string option = "--out");
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
  bool guarded_ = false;
  OutputGuard guard_;
  std::string option_;
};

namespace internal {
// Removes ".<name>.tmp-<pid>" and ".<name>.old-<pid>" entries next to
// `target` whose process no longer runs (or is this process). Exposed for
// tests.
void RemoveStaleTemporaries(const std::filesystem::path& target);
}  // namespace internal

}  // namespace relit
