#include "pipeline/hash.h"

#include <algorithm>
#include <fstream>
#include <memory>
#include <vector>

#include <openssl/evp.h>

#include "core/atomic_output.h"
#include "core/error.h"

namespace relit::pipeline {

namespace fs = std::filesystem;

namespace {

class Sha256 {
 public:
  Sha256() : context_(EVP_MD_CTX_new(), EVP_MD_CTX_free) {
    RELIT_CHECK(context_ && EVP_DigestInit_ex(context_.get(), EVP_sha256(), nullptr) == 1);
  }
  void Update(const void* data, size_t size) {
    RELIT_CHECK(EVP_DigestUpdate(context_.get(), data, size) == 1);
  }
  std::string HexDigest() {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int length = 0;
    RELIT_CHECK(EVP_DigestFinal_ex(context_.get(), digest, &length) == 1);
    static const char* kHex = "0123456789abcdef";
    std::string hex;
    for (unsigned int i = 0; i < length; ++i) {
      hex += kHex[digest[i] >> 4];
      hex += kHex[digest[i] & 15];
    }
    return hex;
  }

 private:
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> context_;
};

int64_t MtimeNs(const fs::path& path) {
  return static_cast<int64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(
          fs::last_write_time(path).time_since_epoch())
          .count());
}

}  // namespace

std::string Sha256Hex(const std::string& bytes) {
  Sha256 sha;
  sha.Update(bytes.data(), bytes.size());
  return sha.HexDigest();
}

std::string HashJson(const nlohmann::json& value) { return Sha256Hex(value.dump()); }

HashCache::HashCache(fs::path cache_file) : cache_file_(std::move(cache_file)) {
  if (cache_file_.empty()) return;
  std::ifstream in(cache_file_);
  if (!in) return;
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    for (const auto& [path, e] : j.at("files").items()) {
      entries_[path] = Entry{e.at("size").get<uint64_t>(), e.at("mtime_ns").get<int64_t>(),
                             e.at("sha256").get<std::string>()};
    }
  } catch (const std::exception&) {
    entries_.clear();  // a damaged cache only costs hashing again
  }
}

std::string HashCache::HashFile(const fs::path& path) {
  const std::string key = fs::absolute(path).lexically_normal().string();
  std::error_code error;
  const uint64_t size = fs::file_size(path, error);
  RELIT_REQUIRE(!error, "cannot read ", path.string(), ": ", error.message());
  const int64_t mtime_ns = MtimeNs(path);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = entries_.find(key);
    if (it != entries_.end() && it->second.size == size && it->second.mtime_ns == mtime_ns) {
      return it->second.sha256;
    }
  }
  std::ifstream in(path, std::ios::binary);
  RELIT_REQUIRE(in, "cannot read ", path.string());
  Sha256 sha;
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    sha.Update(buffer.data(), static_cast<size_t>(in.gcount()));
  }
  RELIT_REQUIRE(in.eof(), "error while reading ", path.string());
  const std::string hex = sha.HexDigest();
  std::lock_guard<std::mutex> lock(mutex_);
  entries_[key] = Entry{size, mtime_ns, hex};
  dirty_ = true;
  return hex;
}

std::string HashCache::HashPath(const fs::path& path) {
  std::error_code error;
  if (!fs::exists(path, error)) return "";
  if (!fs::is_directory(path)) return HashFile(path);
  std::vector<std::string> files;
  for (auto it = fs::recursive_directory_iterator(path, fs::directory_options::follow_directory_symlink);
       it != fs::recursive_directory_iterator(); ++it) {
    if (it->is_regular_file()) files.push_back(fs::relative(it->path(), path).generic_string());
  }
  std::sort(files.begin(), files.end());
  std::string listing;
  for (const std::string& file : files) {
    listing += file + " " + HashFile(path / file) + "\n";
  }
  return Sha256Hex(listing);
}

void HashCache::Save() {
  if (cache_file_.empty()) return;
  nlohmann::json files = nlohmann::json::object();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!dirty_) return;
    for (const auto& [path, e] : entries_) {
      std::error_code error;
      if (!fs::exists(path, error)) continue;
      files[path] = {{"size", e.size}, {"mtime_ns", e.mtime_ns}, {"sha256", e.sha256}};
    }
    dirty_ = false;
  }
  AtomicWriteFile(cache_file_, nlohmann::json{{"files", files}}.dump() + "\n");
}

}  // namespace relit::pipeline
