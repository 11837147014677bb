#include "relight/eval_cue_cache.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <system_error>

#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/error.h"
#include "relight/cue_stage.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

uint64_t RendererFingerprint(render::Scene& scene, const Camera& camera, const CueLight& light,
                             const CueRenderSettings& settings, const CueFormat& format) {
  const Intrinsics& full = camera.intrinsics();
  const int width = std::min(full.width, 32);
  const int height = std::max(1, full.height * width / std::max(full.width, 1));
  CueRenderSettings probe = settings;
  probe.samples_per_pixel = 2;
  const Image frame = RenderCueFrame(scene, Camera(full.Scaled(width, height), camera.cam_from_world()), light, probe,
                                     format);
  std::string bytes(frame.data().size() * sizeof(float), '\0');
  std::memcpy(bytes.data(), frame.data().data(), bytes.size());
  return HashString(bytes);
}

EvalCueCache::EvalCueCache(fs::path dir, json common_key, CueFormat format)
    : dir_(std::move(dir)), common_key_(std::move(common_key)), format_(std::move(format)) {
  if (dir_.empty()) return;
  fs::create_directories(dir_);
  // The cache folder's own clock: a file written now has this time or later.
  const fs::path stamp = dir_ / ".start";
  std::ofstream(stamp).put('\n');
  start_ = fs::last_write_time(stamp);
}

Image EvalCueCache::Get(const json& key, const std::function<Image()>& render) {
  if (dir_.empty()) return render();
  json full = common_key_;
  full["frame"] = key;
  const std::string text = full.dump();
  char stem[17];
  std::snprintf(stem, sizeof(stem), "%016llx", static_cast<unsigned long long>(HashString(text)));
  const fs::path exr = dir_ / (std::string(stem) + ".exr"), key_file = dir_ / (std::string(stem) + ".json");
  used_.insert(stem);
  std::error_code ec;
  if (fs::exists(exr, ec) && fs::exists(key_file, ec)) {
    std::ifstream in(key_file);
    const json stored = json::parse(in, nullptr, false);
    if (!stored.is_discarded() && stored == full) {
      try {
        Image frame = ReadCueFrame(exr.string(), format_);
        fs::last_write_time(exr, fs::file_time_type::clock::now(), ec);  // in use: RemoveUnused keeps it
        ++hits_;
        return frame;
      } catch (const Error& e) {
        spdlog::warn("eval: cached cue frame {} unreadable ({}); rendering it again", exr.string(), e.what());
      }
    }
  }
  Image frame = render();
  // Float: a frame read back is bit-identical to this render. The key goes
  // last, so a frame is only ever found complete.
  fs::remove(key_file, ec);
  WriteImage(exr.string(), frame, PixelStorage::kFloat);
  AtomicWriteFile(key_file, full.dump(1));
  ++misses_;
  return frame;
}

int EvalCueCache::RemoveUnused() {
  if (dir_.empty()) return 0;
  int removed = 0;
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir_, ec)) {
    const fs::path& path = entry.path();
    if (path.extension() != ".exr" && path.extension() != ".json") continue;
    // Only the cache's own <16 hex digits> names: nothing else there is deleted.
    const std::string stem = path.stem().string();
    if (stem.size() != 16 || stem.find_first_not_of("0123456789abcdef") != std::string::npos) continue;
    if (used_.count(stem) > 0) continue;
    const auto written = fs::last_write_time(path, ec);
    if (ec || written >= start_) continue;
    if (fs::remove(path, ec) && path.extension() == ".exr") ++removed;
  }
  return removed;
}

}  // namespace relit::relight
