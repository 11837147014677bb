// Cache of the dense path's stereo pair depth maps (the slow part: ~13 s
// per 960x540 frame and its two pairs on 2 cores), so that an interrupted or
// re-run stage, or one with other fusion, Poisson or cleanup options, does
// not match the pairs again.
// W/reconstruct_cache/depth_maps/<frame>__<other frame>_<key>.exr (32-bit
// float, metres along the frame's optical axis, 0 = none); the key hashes
// everything the map depends on: both cameras, both images' sizes and
// modification times, the disparity search box and the SGBM options. A pair
// keeps one entry: writing a new one removes its stale ones.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "reconstruct/reconstruct_options.h"
#include "reconstruct/stereo_depth.h"

namespace relit::reconstruct {

class DepthMapCache {
 public:
  // `dir` empty disables the cache.
  explicit DepthMapCache(std::filesystem::path dir) : dir_(std::move(dir)) {}

  // The cache file of `ref`'s depth map from the pair (ref, other);
  // `ref_image` and `other_image` are their image files.
  std::filesystem::path Entry(const DepthView& ref, const DepthView& other, const std::filesystem::path& ref_image,
                              const std::filesystem::path& other_image, const SceneBox& box,
                              const ProxyOptions& options) const;

  // The cached map, or an empty Mat when there is none (or it is unreadable).
  cv::Mat Load(const std::filesystem::path& entry) const;
  // Writes atomically (temporary file, rename) and removes the frame's
  // other entries (stale keys of the same pair). Failures only warn: the cache is an optimisation.
  void Store(const std::filesystem::path& entry, const cv::Mat& depth) const;

  bool enabled() const { return !dir_.empty(); }

 private:
  std::filesystem::path dir_;
};

}  // namespace relit::reconstruct
