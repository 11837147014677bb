#include "bench/bench_scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>

#include <tbb/enumerable_thread_specific.h>

#include "core/error.h"

namespace relit::bench {


const char* MaterialName(CowMaterial material) {
  return material == CowMaterial::kLambert ? "lambert" : "ggx";
}

Camera BenchSceneSpec::MakeCamera() const {
  return Camera(Intrinsics::FromFov(width, height, horizontal_fov_rad),
                LookAt(camera_eye, camera_target, Eigen::Vector3d::UnitZ()));
}

render::TriangleMesh LoadBenchMesh(BenchSceneSpec* spec) {
  render::TriangleMesh mesh = render::LoadMesh(spec->mesh_path);
  RELIT_REQUIRE(!mesh.triangles.empty(), "benchmark mesh ", spec->mesh_path, " has no triangles");

  // Angle-weighted normals accumulated per distinct position, so vertices that
  // the loader split at UV seams share one normal (as in Blender).
  std::map<std::array<float, 3>, Vec3f> accumulated;
  auto key = [&](int v) {
    const Vec3f& p = mesh.positions[v];
    return std::array<float, 3>{p.x(), p.y(), p.z()};
  };
  for (const Eigen::Vector3i& tri : mesh.triangles) {
    const Vec3f& a = mesh.positions[tri[0]];
    const Vec3f& b = mesh.positions[tri[1]];
    const Vec3f& c = mesh.positions[tri[2]];
    const Vec3f n = (b - a).cross(c - a);
    if (n.squaredNorm() == 0) continue;
    const Vec3f unit = n.normalized();
    const std::array<Vec3f, 3> corner = {a, b, c};
    for (int k = 0; k < 3; ++k) {
      const Vec3f e1 = (corner[(k + 1) % 3] - corner[k]).normalized();
      const Vec3f e2 = (corner[(k + 2) % 3] - corner[k]).normalized();
      const float angle = std::acos(std::clamp(e1.dot(e2), -1.0f, 1.0f));
      auto [it, inserted] = accumulated.try_emplace(key(tri[k]), Vec3f::Zero());
      (void)inserted;
      it->second += angle * unit;
    }
  }
  mesh.normals.assign(mesh.positions.size(), Vec3f::UnitZ());
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    auto it = accumulated.find(key(static_cast<int>(v)));
    if (it != accumulated.end() && it->second.squaredNorm() > 0) mesh.normals[v] = it->second.normalized();
  }

  // The file is +Y up; relit's world is +Z up: rotate +90 degrees about x
  // ((x, y, z) -> (x, -z, y)) and lift the lowest point onto z = 0.
  const Eigen::Affine3f rotate(Eigen::AngleAxisf(0.5f * render::kPi, Vec3f::UnitX()));
  float min_z = std::numeric_limits<float>::infinity();
  for (const Vec3f& p : mesh.positions) min_z = std::min(min_z, (rotate * p).z());
  spec->cow_world_from_object = Eigen::Translation3f(0.0f, 0.0f, -min_z) * rotate;
  return mesh;
}

void BuildRelitScene(const BenchSceneSpec& spec, const render::TriangleMesh& cow,
                     CowMaterial material, render::Scene* scene) {
  render::Material cow_material;
  if (material == CowMaterial::kLambert) {
    cow_material = render::Material::Lambert(Rgb::Constant(spec.lambert_albedo));
  } else {
    // Fresnel fixed at 1 (f0 = 1): Cycles' Glossy BSDF has no Fresnel term.
    cow_material = render::Material::Glossy(Rgb::Zero(), Rgb::Constant(spec.ggx_albedo), spec.ggx_alpha);
    cow_material.f0 = Rgb::Ones();
  }
  cow_material.name = MaterialName(material);
  const int mesh = scene->AddMesh(cow);
  scene->AddInstance(mesh, scene->AddMaterial(cow_material), spec.cow_world_from_object, kCowObjectId);

  render::Material ground = render::Material::Lambert(Rgb::Constant(spec.ground_albedo));
  ground.name = "ground";
  scene->AddObject(render::MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), spec.ground_half_size,
                                    spec.ground_half_size),
                   ground, kGroundObjectId);

  render::PointLight light;
  light.position = spec.light_position;
  light.intensity = Rgb::Constant(spec.light_intensity);
  scene->AddLight(light);
  scene->Commit();
}

namespace {

// Counts (and optionally records) the rays of each rendering thread.
class RecordingObserver : public render::RayObserver {
 public:
  explicit RecordingObserver(bool record) : record_(record) {}
  void OnRay(const Vec3f& origin, const Vec3f& direction, float t_min, float t_max, bool occlusion) override {
    PerThread& local = threads_.local();
    (occlusion ? local.counts.occluded : local.counts.intersected) += 1;
    if (!record_) return;
    RecordedRay ray;
    for (int k = 0; k < 3; ++k) {
      ray.origin[k] = origin[k];
      ray.direction[k] = direction[k];
    }
    ray.t_min = t_min;
    ray.t_max = t_max;
    ray.occlusion = occlusion ? 1u : 0u;
    local.rays.push_back(ray);
  }
  void Collect(RayCounts* counts, std::vector<RecordedRay>* rays) {
    for (PerThread& local : threads_) {
      counts->intersected += local.counts.intersected;
      counts->occluded += local.counts.occluded;
      rays->insert(rays->end(), local.rays.begin(), local.rays.end());
      std::vector<RecordedRay>().swap(local.rays);
    }
  }

 private:
  struct PerThread {
    RayCounts counts;
    std::vector<RecordedRay> rays;
  };
  bool record_;
  tbb::enumerable_thread_specific<PerThread> threads_;
};

}  // namespace

ObservedRender RenderObserved(render::Scene& scene, const Camera& camera, const render::RenderOptions& options,
                              bool record_rays) {
  RecordingObserver observer(record_rays);
  scene.set_ray_observer(&observer);
  ObservedRender result;
  try {
    result.radiance = render::RenderImage(scene, camera, options).radiance;
  } catch (...) {
    scene.set_ray_observer(nullptr);
    throw;
  }
  scene.set_ray_observer(nullptr);
  observer.Collect(&result.counts, &result.rays);
  return result;
}

float MaxAbsDifference(const Image& a, const Image& b) {
  RELIT_CHECK(a.data().size() == b.data().size());
  float worst = 0;
  for (size_t i = 0; i < a.data().size(); ++i) worst = std::max(worst, std::abs(a.data()[i] - b.data()[i]));
  return worst;
}

}  // namespace relit::bench
