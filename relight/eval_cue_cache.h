// Eval's cue frames, kept between runs in W/relight/eval_cues/. Rendering
// them is most of an eval's time (5-7 minutes of the `full` spheres' 10),
// and they depend only on the proxy, its normal map and support plane, the
// view, the light and the cue render settings, never on the models or the
// cue fit. So a second eval of the same workspace (another method, another
// cue-fit option, a retrained model) reads them back.
//
// Each frame is stored as <key hash>.exr (float, so a reread frame is
// bit-identical to the render) beside <key hash>.json, its full key, which
// must match for a hit: a hash collision or a changed input renders again.
// The key includes a fingerprint of the renderer itself (a small probe
// render of the same scene, hashed), so a relit build whose path tracer
// renders differently does not read an older build's frames.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "core/image.h"
#include "relight/cue_frames.h"

namespace relit::relight {

// Hash of a probe render: `scene` under `light` from `camera` shrunk to
// about 32 pixels wide at 2 samples per pixel, with `settings`' depth,
// denoising and seed. Equal for equal renderers (the render is seeded).
uint64_t RendererFingerprint(render::Scene& scene, const Camera& camera, const CueLight& light,
                             const CueRenderSettings& settings, const CueFormat& format);

class EvalCueCache {
 public:
  // `dir` empty: off (every Get renders). `common_key` is merged into every
  // frame's key (the scene's and the settings' share).
  EvalCueCache(std::filesystem::path dir, nlohmann::json common_key, CueFormat format);

  // The frame for `key`: read from the cache on a hit, else `render()`d and
  // stored. A frame that cannot be read (truncated, deleted meanwhile) is
  // rendered again.
  Image Get(const nlohmann::json& key, const std::function<Image()>& render);

  // Deletes the cached frames that this run did not use and that are older
  // than its start (another eval running beside it keeps its frames), so
  // the cache holds about one eval's frames. Returns how many were deleted.
  int RemoveUnused();

  int hits() const { return hits_; }
  int misses() const { return misses_; }
  bool enabled() const { return !dir_.empty(); }

 private:
  std::filesystem::path dir_;
  nlohmann::json common_key_;
  CueFormat format_;
  std::filesystem::file_time_type start_;
  std::set<std::string> used_;  // stems of the frames this run read or wrote
  int hits_ = 0;
  int misses_ = 0;
};

}  // namespace relit::relight
