// Content hashes (SHA-256, OpenSSL) of files, folders and JSON values, for
// the rerun rules of the orchestrator: a step reruns when the hash of one of
// its inputs, of its parameters or of its tool changed, never because a
// timestamp moved.
//
// Hashing large inputs again on every `relit run` would be slow (videos,
// thousands of frames), so HashCache remembers each file's hash together with
// its size and modification time (like git's index or DVC's state): a file
// whose size and mtime are unchanged is not read again.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <mutex>
#include <string>

#include <nlohmann/json.hpp>

namespace relit::pipeline {

// Lower-case hex SHA-256 of a byte string.
std::string Sha256Hex(const std::string& bytes);

// SHA-256 of the canonical text of a JSON value (keys sorted, no spaces).
std::string HashJson(const nlohmann::json& value);

class HashCache {
 public:
  // `cache_file` holds the remembered hashes ("" = remember nothing across
  // runs). A missing or unreadable cache file is simply an empty cache.
  explicit HashCache(std::filesystem::path cache_file = {});

  // SHA-256 of a regular file's content. Throws relit::Error when it cannot
  // be read.
  std::string HashFile(const std::filesystem::path& path);

  // Hash of a file or of a folder tree: for a folder, the SHA-256 of the
  // sorted list "relative/path <file hash>" of every regular file below it
  // (symlinks followed), so renaming, adding or changing any file changes
  // it. Returns "" when `path` does not exist.
  std::string HashPath(const std::filesystem::path& path);

  // Writes the cache file (atomically). Entries of files that no longer
  // exist are dropped.
  void Save();

 private:
  struct Entry {
    uint64_t size = 0;
    int64_t mtime_ns = 0;
    std::string sha256;
  };
  std::filesystem::path cache_file_;
  std::mutex mutex_;
  std::map<std::string, Entry> entries_;  // by absolute path
  bool dirty_ = false;
};

}  // namespace relit::pipeline
