// Bare Embree 3 traversal of recorded rays: the lower bound on what the path
// tracer could achieve with the same rays, without shading, sampling, hit
// reconstruction or image bookkeeping.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "bench/bench_scene.h"
#include "bench/bench_util.h"
#include "core/render/scene.h"

namespace relit::bench {

struct RawTraceResult {
  double seconds = 0;     // best wall time of the repeats
  double cpu_seconds = 0; // best process CPU time (all threads) of the repeats
  uint64_t rays = 0;
  uint64_t hits = 0;      // intersect rays that hit + shadow rays that were blocked
  double RaysPerSecond() const { return seconds > 0 ? static_cast<double>(rays) / seconds : 0; }
};

// Its own RTCDevice/RTCScene built from the meshes and instances of a relit
// scene, either with relit's layout (one BVH per mesh under a top-level
// instance BVH) or flattened into one world-space BVH.
class RawEmbreeScene {
 public:
  enum class Layout { kInstanced, kFlat };
  RawEmbreeScene(const render::Scene& scene, Layout layout);
  ~RawEmbreeScene();
  RawEmbreeScene(const RawEmbreeScene&) = delete;
  RawEmbreeScene& operator=(const RawEmbreeScene&) = delete;

  // Traces every ray (rtcIntersect1, or rtcOccluded1 for shadow rays) with a
  // TBB parallel_for over chunks of rays, `repeats` times; reports the best.
  RawTraceResult Trace(const std::vector<RecordedRay>& rays, int repeats) const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace relit::bench
