#include "reconstruct/depth_cache.h"

#include <cstdio>
#include <functional>
#include <sstream>
#include <system_error>

#include <spdlog/spdlog.h>
#include <unistd.h>

#include "core/error.h"
#include "core/image.h"

namespace relit::reconstruct {
namespace {

namespace fs = std::filesystem;

// Bump when the depth computation changes in a way the options do not show.
constexpr int kCacheVersion = 1;

void AppendCamera(std::ostringstream& key, const DepthView& view) {
  const Intrinsics& k = view.camera.intrinsics();
  const Rigid3& pose = view.camera.cam_from_world();
  key << view.name << ' ' << k.width << ' ' << k.height << ' ' << k.fx << ' ' << k.fy << ' ' << k.cx << ' ' << k.cy
      << ' ' << pose.rotation.coeffs().transpose() << ' ' << pose.translation.transpose() << ';';
}

std::string FileStem(const std::string& frame_name) {
  std::string stem = frame_name;
  for (char& c : stem) {
    if (c == '/') c = '_';
  }
  return stem;
}

}  // namespace

fs::path DepthMapCache::Entry(const DepthView& ref, const DepthView& other, const fs::path& ref_image,
                              const fs::path& other_image, const SceneBox& box, const ProxyOptions& options) const {
  std::ostringstream key;
  key.precision(17);
  key << kCacheVersion << ';';
  AppendCamera(key, ref);
  AppendCamera(key, other);
  for (const fs::path& image : {ref_image, other_image}) {
    std::error_code error;
    const auto size = fs::file_size(image, error);
    const auto time = fs::last_write_time(image, error).time_since_epoch().count();
    key << image.filename().string() << ' ' << size << ' ' << time << ';';
  }
  key << box.min.transpose() << ' ' << box.max.transpose() << ';' << options.block_size_px << ' '
      << options.uniqueness_ratio << ' ' << options.speckle_window_px << ' ' << options.max_left_right_difference_px;
  char hash[17];
  std::snprintf(hash, sizeof(hash), "%016zx", std::hash<std::string>{}(key.str()));
  return dir_ / (FileStem(ref.name) + "__" + FileStem(other.name) + "_" + hash + ".exr");
}

cv::Mat DepthMapCache::Load(const fs::path& entry) const {
  if (!enabled() || !fs::exists(entry)) return {};
  try {
    cv::Mat depth = ReadImage(entry.string()).ToMat();
    if (depth.type() == CV_32FC1) return depth;
  } catch (const Error& e) {
    spdlog::warn("depth map cache: ignoring {}: {}", entry.string(), e.what());
  }
  return {};
}

void DepthMapCache::Store(const fs::path& entry, const cv::Mat& depth) const {
  if (!enabled()) return;
  try {
    fs::create_directories(dir_);
    const fs::path temp = dir_ / (".tmp-" + std::to_string(getpid()) + "-" + entry.filename().string());
    WriteImage(temp.string(), Image::FromMat(depth), PixelStorage::kFloat);
    fs::rename(temp, entry);
    // The pair's stem is everything before the last '_' (the key).
    const std::string name = entry.filename().string();
    const std::string prefix = name.substr(0, name.rfind('_') + 1);
    for (const fs::directory_entry& other : fs::directory_iterator(dir_)) {
      const std::string other_name = other.path().filename().string();
      if (other_name != name && other_name.rfind(prefix, 0) == 0 && other_name.size() == name.size()) {
        fs::remove(other.path());
      }
    }
  } catch (const std::exception& e) {
    spdlog::warn("depth map cache: could not write {}: {}", entry.string(), e.what());
  }
}

}  // namespace relit::reconstruct
