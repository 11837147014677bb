#include "core/render/scene.h"

#include <cmath>

#include <embree3/rtcore.h>

#include "core/error.h"
#include "core/render/embree_triangles.h"

namespace relit::render {

struct Scene::EmbreeState {
  RTCDevice device = nullptr;
  RTCScene top = nullptr;
  std::vector<RTCScene> prototypes;

  EmbreeState() {
    device = rtcNewDevice(nullptr);
    RELIT_REQUIRE(device != nullptr, "cannot create Embree device (error ",
                  static_cast<int>(rtcGetDeviceError(nullptr)), ")");
  }
  ~EmbreeState() {
    if (top) rtcReleaseScene(top);
    for (RTCScene s : prototypes) rtcReleaseScene(s);
    if (device) rtcReleaseDevice(device);
  }
};

Material Material::Lambert(const Rgb& albedo) {
  Material m;
  m.diffuse_albedo = albedo;
  m.specular_albedo = Rgb::Zero();
  return m;
}

Material Material::Glossy(const Rgb& diffuse, const Rgb& specular, float alpha) {
  Material m;
  m.diffuse_albedo = diffuse;
  m.specular_albedo = specular;
  m.roughness = Rgb::Constant(alpha);
  return m;
}

BsdfParams Material::At(const Vec2f& uv) const {
  BsdfParams p;
  p.diffuse = diffuse_albedo.Eval(uv);
  p.specular = specular_albedo.Eval(uv);
  p.alpha = roughness.Eval(uv)[0];
  p.f0 = f0;
  return p;
}

Scene::Scene() : embree_(std::make_unique<EmbreeState>()) {}
Scene::~Scene() = default;

int Scene::AddMesh(TriangleMesh mesh) {
  mesh.Check("scene mesh");
  if (!mesh.has_normals()) mesh.ComputeVertexNormals();
  meshes_.push_back(std::move(mesh));
  committed_ = false;
  return static_cast<int>(meshes_.size()) - 1;
}

int Scene::AddMaterial(Material material) {
  materials_.push_back(std::move(material));
  return static_cast<int>(materials_.size()) - 1;
}

int Scene::AddInstance(int mesh, int material, const Eigen::Affine3f& world_from_object,
                       int object_id) {
  RELIT_CHECK(mesh >= 0 && mesh < static_cast<int>(meshes_.size()));
  RELIT_CHECK(material >= 0 && material < static_cast<int>(materials_.size()));
  instances_.push_back({mesh, material, object_id, -1, world_from_object,
                        world_from_object.linear().inverse().transpose()});
  committed_ = false;
  return static_cast<int>(instances_.size()) - 1;
}

int Scene::AddObject(TriangleMesh mesh, Material material, int object_id) {
  const int m = AddMesh(std::move(mesh));
  return AddInstance(m, AddMaterial(std::move(material)), Eigen::Affine3f::Identity(), object_id);
}

void Scene::AddLight(const QuadLight& light) {
  RELIT_REQUIRE(light.Area() > 0, "quad light has zero area");
  quad_lights_.push_back(light);
  // Emitters are geometry too, so camera and BSDF rays can hit them (MIS).
  TriangleMesh quad;
  quad.positions = {light.corner, light.corner + light.edge_u,
                    light.corner + light.edge_u + light.edge_v, light.corner + light.edge_v};
  quad.normals.assign(4, light.Normal());
  quad.triangles = {{0, 1, 2}, {0, 2, 3}};
  const int mesh = AddMesh(std::move(quad));
  instances_.push_back({mesh, -1, -1, static_cast<int>(quad_lights_.size()) - 1,
                        Eigen::Affine3f::Identity(), Eigen::Matrix3f::Identity()});
  committed_ = false;
}

void Scene::ClearLights() {
  point_lights_.clear();
  directional_lights_.clear();
  environment_ = EnvironmentLight();
  if (!quad_lights_.empty()) {
    quad_lights_.clear();
    std::vector<Instance> kept;
    for (const Instance& instance : instances_) {
      if (instance.quad_light < 0) kept.push_back(instance);
    }
    instances_ = std::move(kept);
    committed_ = false;
  }
}

int Scene::light_count() const {
  return static_cast<int>(point_lights_.size() + directional_lights_.size() + quad_lights_.size()) +
         (environment_.valid() ? 1 : 0);
}

void AttachTriangles(RTCDevice device, RTCScene target, const std::vector<Eigen::Vector3f>& positions,
                     const std::vector<Eigen::Vector3i>& triangles) {
  RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), positions.size()));
  for (size_t i = 0; i < positions.size(); ++i) {
    for (int k = 0; k < 3; ++k) vertices[3 * i + k] = positions[i][k];
  }
  auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), triangles.size()));
  for (size_t i = 0; i < triangles.size(); ++i) {
    for (int k = 0; k < 3; ++k) indices[3 * i + k] = static_cast<unsigned>(triangles[i][k]);
  }
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(target, geometry);
  rtcReleaseGeometry(geometry);
}

void Scene::Commit() {
  EmbreeState& e = *embree_;
  if (e.top) rtcReleaseScene(e.top);
  for (RTCScene s : e.prototypes) rtcReleaseScene(s);
  e.prototypes.clear();
  for (const TriangleMesh& mesh : meshes_) {
    RTCScene proto = rtcNewScene(e.device);
    AttachTriangles(e.device, proto, mesh.positions, mesh.triangles);
    rtcSetSceneBuildQuality(proto, RTC_BUILD_QUALITY_HIGH);
    rtcCommitScene(proto);
    e.prototypes.push_back(proto);
  }
  e.top = rtcNewScene(e.device);
  for (size_t i = 0; i < instances_.size(); ++i) {
    const Instance& instance = instances_[i];
    RTCGeometry geometry = rtcNewGeometry(e.device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(geometry, e.prototypes[instance.mesh]);
    const Eigen::Matrix<float, 3, 4> xfm = instance.world_from_object.matrix().topRows<3>();
    rtcSetGeometryTransform(geometry, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm.data());
    rtcCommitGeometry(geometry);
    rtcAttachGeometryByID(e.top, geometry, static_cast<unsigned>(i));
    rtcReleaseGeometry(geometry);
  }
  rtcCommitScene(e.top);
  RELIT_REQUIRE(rtcGetDeviceError(e.device) == RTC_ERROR_NONE, "Embree failed to build the scene (error ",
                static_cast<int>(rtcGetDeviceError(e.device)), ")");
  committed_ = true;
}

bool Scene::Intersect(const Vec3f& origin, const Vec3f& direction, float t_min, float t_max,
                      Hit* hit) const {
  RELIT_CHECK(committed_);
  if (ray_observer_) ray_observer_->OnRay(origin, direction, t_min, t_max, false);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rayhit;
  rayhit.ray.org_x = origin.x();
  rayhit.ray.org_y = origin.y();
  rayhit.ray.org_z = origin.z();
  rayhit.ray.dir_x = direction.x();
  rayhit.ray.dir_y = direction.y();
  rayhit.ray.dir_z = direction.z();
  rayhit.ray.tnear = t_min;
  rayhit.ray.tfar = t_max;
  rayhit.ray.time = 0;
  rayhit.ray.mask = 0xFFFFFFFFu;
  rayhit.ray.id = 0;
  rayhit.ray.flags = 0;
  rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rayhit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(embree_->top, &context, &rayhit);
  if (rayhit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;

  const Instance& instance = instances_[rayhit.hit.instID[0]];
  const TriangleMesh& mesh = meshes_[instance.mesh];
  const Eigen::Vector3i& tri = mesh.triangles[rayhit.hit.primID];
  const float b1 = rayhit.hit.u, b2 = rayhit.hit.v, b0 = 1.0f - b1 - b2;
  hit->t = rayhit.ray.tfar;
  hit->position = origin + hit->t * direction;
  // Geometry from our own copy of the mesh: Embree reports Ng in object space for instances.
  const Vec3f p0 = instance.world_from_object * mesh.positions[tri[0]];
  const Vec3f p1 = instance.world_from_object * mesh.positions[tri[1]];
  const Vec3f p2 = instance.world_from_object * mesh.positions[tri[2]];
  hit->geometric_normal = (p1 - p0).cross(p2 - p0).normalized();
  hit->uv = mesh.has_uvs() ? Vec2f(b0 * mesh.uvs[tri[0]] + b1 * mesh.uvs[tri[1]] + b2 * mesh.uvs[tri[2]])
                           : Vec2f::Zero();
  Vec3f n = b0 * mesh.normals[tri[0]] + b1 * mesh.normals[tri[1]] + b2 * mesh.normals[tri[2]];
  const Texture& normal_map = materials_[instance.material].normal_map;
  if (!normal_map.is_constant() && mesh.has_uvs()) {
    const Rgb mapped = normal_map.Eval(hit->uv);
    if (mapped.matrix().squaredNorm() > 1e-6f) n = Vec3f(mapped[0], mapped[1], mapped[2]);
  }
  const Vec3f shading = instance.normal_matrix * n;
  hit->shading_normal = shading.norm() > 0 ? Vec3f(shading.normalized()) : hit->geometric_normal;
  hit->barycentric = Vec2f(b1, b2);
  hit->instance = static_cast<int>(rayhit.hit.instID[0]);
  hit->triangle = static_cast<int>(rayhit.hit.primID);
  hit->material = instance.material;
  hit->object_id = instance.object_id;
  hit->quad_light = instance.quad_light;
  return true;
}

bool Scene::Occluded(const Vec3f& origin, const Vec3f& direction, float t_min, float t_max) const {
  RELIT_CHECK(committed_);
  if (ray_observer_) ray_observer_->OnRay(origin, direction, t_min, t_max, true);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray;
  ray.org_x = origin.x();
  ray.org_y = origin.y();
  ray.org_z = origin.z();
  ray.dir_x = direction.x();
  ray.dir_y = direction.y();
  ray.dir_z = direction.z();
  ray.tnear = t_min;
  ray.tfar = t_max;
  ray.time = 0;
  ray.mask = 0xFFFFFFFFu;
  ray.id = 0;
  ray.flags = 0;
  rtcOccluded1(embree_->top, &context, &ray);
  return ray.tfar < 0;  // Embree sets tfar to -inf on a hit
}

void Scene::BoundingSphere(Vec3f* centre, float* radius) const {
  Eigen::AlignedBox3f box;
  for (const Instance& instance : instances_) {
    for (const auto& p : meshes_[instance.mesh].positions) box.extend(instance.world_from_object * p);
  }
  if (box.isEmpty()) {
    *centre = Vec3f::Zero();
    *radius = 1;
    return;
  }
  *centre = box.center();
  *radius = 0.5f * box.diagonal().norm();
}

}  // namespace relit::render
