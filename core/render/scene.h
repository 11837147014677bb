// Embree 3 scene: mesh prototypes instanced with transforms, materials and
// lights. Build once, Commit(), then query from many threads.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/render/bsdf.h"
#include "core/render/light.h"
#include "core/render/mesh.h"
#include "core/render/texture.h"

namespace relit::render {

// Material = textured Lambert + textured microfacet layer (either may be zero).
struct Material {
  std::string name;
  Texture diffuse_albedo = Rgb(0.5f, 0.5f, 0.5f);  // colour textures are sRGB-decoded on load
  Texture specular_albedo = Rgb::Zero();
  Texture roughness = Rgb::Constant(0.3f);   // GGX alpha, read from the first channel
  Rgb f0 = Rgb::Constant(0.04f);
  // Object-space normal map (unit normals stored as raw floats, read at the
  // hit's uv): the shading normal where the mesh is coarser than the
  // surface it stands for. A constant (the default, zero) = the mesh's
  // interpolated vertex normals. Texels outside the UV charts must hold a
  // continuation of the charts (bilinear reads at chart borders).
  Texture normal_map = Rgb::Zero();
  // Radiance cues only (cue_renderer.h): the object's fitted cue weights, one
  // RGB texture per basis material. When set, the object wears at every path
  // vertex after the primary hit the mixture sum_k w_k f_k of the basis
  // materials (the same in every cue) instead of each cue's own basis, so
  // the cues hold inter-reflections between parts of different materials
  // (a copper sphere mirroring an orange one). Empty = the basis itself.
  std::vector<Texture> cue_weights;

  static Material Lambert(const Rgb& albedo);
  static Material Glossy(const Rgb& diffuse, const Rgb& specular, float alpha);
  BsdfParams At(const Vec2f& uv) const;
};

struct Hit {
  float t = 0;                 // ray parameter (metres for unit directions)
  Vec3f position;              // world
  Vec3f geometric_normal;      // world, unit, facing the ray origin side not guaranteed
  Vec3f shading_normal;        // world, unit, interpolated vertex normal if present
  Vec2f uv = Vec2f::Zero();    // interpolated texture coordinates (0 if none)
  Vec2f barycentric;           // Embree (u, v) of the triangle
  int instance = -1;
  int triangle = -1;
  int material = -1;
  int object_id = -1;
  int quad_light = -1;         // index into quad_lights() when an emitter was hit
};

// Sees every ray a Scene traces (for benchmarks and statistics). Called
// concurrently from the rendering threads: implementations must be thread-safe.
class RayObserver {
 public:
  virtual ~RayObserver() = default;
  virtual void OnRay(const Vec3f& origin, const Vec3f& direction, float t_min, float t_max,
                     bool occlusion) = 0;
};

class Scene {
 public:
  Scene();
  ~Scene();
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  int AddMesh(TriangleMesh mesh);  // returns the prototype index
  int AddMaterial(Material material);
  // Places a prototype in the world; object_id is reported in AOVs and alpha.
  int AddInstance(int mesh, int material, const Eigen::Affine3f& world_from_object, int object_id);
  // Convenience: mesh + material + identity instance.
  int AddObject(TriangleMesh mesh, Material material, int object_id);

  void AddLight(const PointLight& light) { point_lights_.push_back(light); }
  void AddLight(const DirectionalLight& light) { directional_lights_.push_back(light); }
  void AddLight(const QuadLight& light);
  void SetEnvironment(EnvironmentLight environment) { environment_ = std::move(environment); }
  void ClearLights();

  // Builds the acceleration structures; call after all Add* and before queries.
  void Commit();

  bool Intersect(const Vec3f& origin, const Vec3f& direction, float t_min, float t_max,
                 Hit* hit) const;
  bool Occluded(const Vec3f& origin, const Vec3f& direction, float t_min, float t_max) const;

  // Optional observer of every Intersect/Occluded call (nullptr = none).
  void set_ray_observer(RayObserver* observer) { ray_observer_ = observer; }

  const std::vector<PointLight>& point_lights() const { return point_lights_; }
  const std::vector<DirectionalLight>& directional_lights() const { return directional_lights_; }
  const std::vector<QuadLight>& quad_lights() const { return quad_lights_; }
  const EnvironmentLight& environment() const { return environment_; }
  const Material& material(int index) const { return materials_[index]; }
  const TriangleMesh& mesh(int index) const { return meshes_[index]; }
  int light_count() const;
  // Bounding sphere of all geometry (for directional-light footprints).
  void BoundingSphere(Vec3f* centre, float* radius) const;

  struct Instance {
    int mesh, material, object_id, quad_light;
    Eigen::Affine3f world_from_object;
    Eigen::Matrix3f normal_matrix;  // inverse transpose of the linear part
  };
  const std::vector<Instance>& instances() const { return instances_; }

 private:
  struct EmbreeState;
  std::unique_ptr<EmbreeState> embree_;
  std::vector<TriangleMesh> meshes_;
  std::vector<Material> materials_;
  std::vector<Instance> instances_;
  std::vector<PointLight> point_lights_;
  std::vector<DirectionalLight> directional_lights_;
  std::vector<QuadLight> quad_lights_;
  EnvironmentLight environment_;
  bool committed_ = false;
  RayObserver* ray_observer_ = nullptr;
};

}  // namespace relit::render
