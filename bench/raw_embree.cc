#include "bench/raw_embree.h"

#include <algorithm>
#include <atomic>
#include <chrono>

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "core/render/embree_triangles.h"
#include "core/run_record.h"

namespace relit::bench {

struct RawEmbreeScene::State {
  RTCDevice device = nullptr;
  RTCScene top = nullptr;
  std::vector<RTCScene> prototypes;
  ~State() {
    if (top) rtcReleaseScene(top);
    for (RTCScene s : prototypes) rtcReleaseScene(s);
    if (device) rtcReleaseDevice(device);
  }
};

namespace {

// Attaches a triangle geometry holding `mesh` with every vertex mapped by
// `transform` to `target`.
void AttachTriangles(RTCDevice device, RTCScene target, const render::TriangleMesh& mesh,
                     const Eigen::Affine3f& transform) {
  std::vector<Eigen::Vector3f> positions;
  positions.reserve(mesh.positions.size());
  for (const Eigen::Vector3f& p : mesh.positions) positions.push_back(transform * p);
  render::AttachTriangles(device, target, positions, mesh.triangles);
}

}  // namespace

RawEmbreeScene::RawEmbreeScene(const render::Scene& scene, Layout layout) : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.device = rtcNewDevice(nullptr);
  RELIT_REQUIRE(s.device != nullptr, "cannot create an Embree device");
  s.top = rtcNewScene(s.device);
  if (layout == Layout::kFlat) {
    for (const render::Scene::Instance& instance : scene.instances()) {
      AttachTriangles(s.device, s.top, scene.mesh(instance.mesh), instance.world_from_object);
    }
    rtcSetSceneBuildQuality(s.top, RTC_BUILD_QUALITY_HIGH);
  } else {
    // Same layout as relit's Scene::Commit.
    int mesh_count = 0;
    for (const render::Scene::Instance& instance : scene.instances()) {
      mesh_count = std::max(mesh_count, instance.mesh + 1);
    }
    for (int m = 0; m < mesh_count; ++m) {
      RTCScene proto = rtcNewScene(s.device);
      AttachTriangles(s.device, proto, scene.mesh(m), Eigen::Affine3f::Identity());
      rtcSetSceneBuildQuality(proto, RTC_BUILD_QUALITY_HIGH);
      rtcCommitScene(proto);
      s.prototypes.push_back(proto);
    }
    for (const render::Scene::Instance& instance : scene.instances()) {
      RTCGeometry geometry = rtcNewGeometry(s.device, RTC_GEOMETRY_TYPE_INSTANCE);
      rtcSetGeometryInstancedScene(geometry, s.prototypes[instance.mesh]);
      const Eigen::Matrix<float, 3, 4> xfm = instance.world_from_object.matrix().topRows<3>();
      rtcSetGeometryTransform(geometry, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm.data());
      rtcCommitGeometry(geometry);
      rtcAttachGeometry(s.top, geometry);
      rtcReleaseGeometry(geometry);
    }
  }
  rtcCommitScene(s.top);
  RELIT_REQUIRE(rtcGetDeviceError(s.device) == RTC_ERROR_NONE, "Embree failed to build the raw scene");
}

RawEmbreeScene::~RawEmbreeScene() = default;

RawTraceResult RawEmbreeScene::Trace(const std::vector<RecordedRay>& rays, int repeats) const {
  RawTraceResult result;
  result.rays = rays.size();
  result.seconds = -1;
  result.cpu_seconds = -1;
  RTCScene top = state_->top;
  for (int r = 0; r < std::max(1, repeats); ++r) {
    std::atomic<uint64_t> hits{0};
    const double cpu_start = ProcessCpuSeconds();
    const auto start = std::chrono::steady_clock::now();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 4096), [&](const tbb::blocked_range<size_t>& range) {
      RTCIntersectContext context;
      rtcInitIntersectContext(&context);
      uint64_t local_hits = 0;
      for (size_t i = range.begin(); i < range.end(); ++i) {
        const RecordedRay& in = rays[i];
        RTCRayHit rayhit;
        RTCRay& ray = rayhit.ray;
        ray.org_x = in.origin[0];
        ray.org_y = in.origin[1];
        ray.org_z = in.origin[2];
        ray.dir_x = in.direction[0];
        ray.dir_y = in.direction[1];
        ray.dir_z = in.direction[2];
        ray.tnear = in.t_min;
        ray.tfar = in.t_max;
        ray.time = 0;
        ray.mask = 0xFFFFFFFFu;
        ray.id = 0;
        ray.flags = 0;
        if (in.occlusion) {
          rtcOccluded1(top, &context, &ray);
          local_hits += ray.tfar < 0 ? 1 : 0;
        } else {
          rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
          rayhit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
          rtcIntersect1(top, &context, &rayhit);
          local_hits += rayhit.hit.geomID != RTC_INVALID_GEOMETRY_ID ? 1 : 0;
        }
      }
      hits += local_hits;
    });
    const double seconds = SecondsSince(start);
    const double cpu_seconds = ProcessCpuSeconds() - cpu_start;
    if (result.seconds < 0 || seconds < result.seconds) result.seconds = seconds;
    if (result.cpu_seconds < 0 || cpu_seconds < result.cpu_seconds) result.cpu_seconds = cpu_seconds;
    result.hits = hits.load();
  }
  return result;
}

}  // namespace relit::bench
