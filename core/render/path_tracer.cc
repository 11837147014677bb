#include "core/render/path_tracer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/error.h"

namespace relit::render {

void RenderOptions::Check() const {
  RELIT_REQUIRE(samples_per_pixel >= 1 && samples_per_pixel <= 1 << 16,
                "samples_per_pixel must be in [1, 65536], got ", samples_per_pixel);
  RELIT_REQUIRE(max_depth >= 1 && max_depth <= 64, "max_depth must be in [1, 64], got ", max_depth);
  RELIT_REQUIRE(russian_roulette_depth >= 1, "russian_roulette_depth must be >= 1");
  RELIT_REQUIRE(gaussian_stddev_px > 0 && gaussian_stddev_px <= 4,
                "gaussian_stddev_px must be in (0, 4] pixels, got ", gaussian_stddev_px);
}

namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();

// Ray origin pushed off the surface along the geometric normal, on the side
// the new ray leaves towards; the push scales with the coordinates' size.
Vec3f OffsetOrigin(const Vec3f& p, const Vec3f& ng, const Vec3f& direction) {
  const float scale = 1e-4f * (1.0f + p.cwiseAbs().maxCoeff());
  return p + (ng.dot(direction) > 0 ? scale : -scale) * ng;
}

struct LightSample {
  Vec3f wi;
  float distance = kInfinity;
  Rgb radiance = Rgb::Zero();
  float pdf = 0;  // solid angle; ignored for delta lights
  bool delta = false;
};

// Picks one light uniformly and samples a direction towards it from `p`.
bool SampleOneLight(const Scene& scene, const Vec3f& p, Rng& rng, LightSample* s, float* select_pdf) {
  const int n_point = static_cast<int>(scene.point_lights().size());
  const int n_dir = static_cast<int>(scene.directional_lights().size());
  const int n_quad = static_cast<int>(scene.quad_lights().size());
  const int count = scene.light_count();
  if (count == 0) return false;
  *select_pdf = 1.0f / count;
  int index = std::min(static_cast<int>(rng.Uniform() * count), count - 1);
  const Vec2f u = rng.Uniform2();
  if (index < n_point) {
    const PointLight& light = scene.point_lights()[index];
    const Vec3f d = light.position - p;
    const float dist2 = d.squaredNorm();
    if (dist2 <= 0) return false;
    s->distance = std::sqrt(dist2);
    s->wi = d / s->distance;
    s->radiance = light.intensity / dist2;
    s->delta = true;
    return true;
  }
  index -= n_point;
  if (index < n_dir) {
    const DirectionalLight& light = scene.directional_lights()[index];
    s->wi = light.direction_to_light.normalized();
    s->radiance = light.irradiance;
    s->delta = true;
    return true;
  }
  index -= n_dir;
  if (index < n_quad) {
    const QuadLight& light = scene.quad_lights()[index];
    const Vec3f q = light.corner + u.x() * light.edge_u + u.y() * light.edge_v;
    const Vec3f d = q - p;
    const float dist2 = d.squaredNorm();
    s->distance = std::sqrt(dist2);
    s->wi = d / s->distance;
    const float cos_light = -s->wi.dot(light.Normal());
    if (cos_light <= 0) return false;
    s->radiance = light.radiance;
    s->pdf = dist2 / (light.Area() * cos_light);
    return true;
  }
  s->wi = scene.environment().Sample(u, &s->pdf);
  if (!(s->pdf > 0)) return false;
  s->radiance = scene.environment().Eval(s->wi);
  return true;
}

// Solid-angle pdf that SampleOneLight picks direction wi hitting quad light q at distance t.
float QuadLightPdf(const QuadLight& light, const Vec3f& wi, float t) {
  const float cos_light = -wi.dot(light.Normal());
  if (cos_light <= 0) return 0;
  return t * t / (light.Area() * cos_light);
}

}  // namespace

Rgb TraceRadiance(const Scene& scene, const Vec3f& origin_in, const Vec3f& direction_in,
                  const RenderOptions& options, Rng& rng) {
  Rgb radiance = Rgb::Zero();
  Rgb throughput = Rgb::Ones();
  Vec3f origin = origin_in, direction = direction_in.normalized();
  float previous_bsdf_pdf = 0;
  bool from_camera = true;
  const float select_pdf = scene.light_count() > 0 ? 1.0f / scene.light_count() : 0.0f;

  for (int bounce = 0;; ++bounce) {
    Hit hit;
    if (!scene.Intersect(origin, direction, 0.0f, kInfinity, &hit)) {
      if (scene.environment().valid() && (!from_camera || options.environment_visible)) {
        const float weight = from_camera ? 1.0f
                                         : PowerHeuristic(previous_bsdf_pdf,
                                                          select_pdf * scene.environment().Pdf(direction));
        radiance += throughput * scene.environment().Eval(direction) * weight;
      }
      break;
    }
    if (hit.quad_light >= 0) {
      const QuadLight& light = scene.quad_lights()[hit.quad_light];
      if (direction.dot(light.Normal()) < 0) {
        const float weight = from_camera ? 1.0f
                                         : PowerHeuristic(previous_bsdf_pdf,
                                                          select_pdf * QuadLightPdf(light, direction, hit.t));
        radiance += throughput * light.radiance * weight;
      }
      break;
    }
    if (bounce >= options.max_depth) break;

    // Two-sided shading: flip the frame to the side the ray arrives from.
    Vec3f ng = hit.geometric_normal, ns = hit.shading_normal;
    if (ng.dot(direction) > 0) ng = -ng;
    if (ns.dot(ng) < 0) ns = -ns;
    const Frame frame(ns);
    const Vec3f wo = frame.ToLocal(-direction);
    if (wo.z() <= 0) break;
    const BsdfParams bsdf = scene.material(hit.material).At(hit.uv);

    // Next-event estimation.
    LightSample ls;
    float light_select_pdf = 0;
    if (SampleOneLight(scene, hit.position, rng, &ls, &light_select_pdf) && ng.dot(ls.wi) > 0) {
      const Vec3f wi = frame.ToLocal(ls.wi);
      const Rgb f = EvalBsdf(bsdf, wo, wi);
      if ((f > 0).any()) {
        const Vec3f shadow_origin = OffsetOrigin(hit.position, ng, ls.wi);
        Vec3f shadow_direction = ls.wi;
        float t_max = kInfinity;
        if (!std::isinf(ls.distance)) {
          // Aim from the offset origin so the ray stops short of an emitter's surface.
          const Vec3f to_light = hit.position + ls.distance * ls.wi - shadow_origin;
          t_max = to_light.norm() * (1.0f - 1e-4f);
          shadow_direction = to_light.normalized();
        }
        if (!scene.Occluded(shadow_origin, shadow_direction, 0.0f, t_max)) {
          const float cos_i = wi.z();
          if (ls.delta) {
            radiance += throughput * f * ls.radiance * (cos_i / light_select_pdf);
          } else {
            const float light_pdf = light_select_pdf * ls.pdf;
            const float weight = PowerHeuristic(light_pdf, PdfBsdf(bsdf, wo, wi));
            radiance += throughput * f * ls.radiance * (cos_i * weight / light_pdf);
          }
        }
      }
    }

    // Continue the path by sampling the BSDF.
    BsdfSample bs;
    const float u_lobe = rng.Uniform();
    if (!SampleBsdf(bsdf, wo, u_lobe, rng.Uniform2(), &bs)) break;
    const Vec3f wi_world = frame.ToWorld(bs.wi);
    if (ng.dot(wi_world) <= 0) break;  // shading normal sent the ray under the surface
    throughput *= bs.weight;
    previous_bsdf_pdf = bs.pdf;
    from_camera = false;
    origin = OffsetOrigin(hit.position, ng, wi_world);
    direction = wi_world;

    if (bounce + 1 >= options.russian_roulette_depth) {
      const float q = std::min(0.95f, throughput.maxCoeff());
      if (rng.Uniform() >= q) break;
      throughput /= q;
    }
    if (!throughput.allFinite()) break;
  }
  return radiance.allFinite() ? radiance : Rgb::Zero();
}

namespace {

// Barycentric coordinates of point q in the plane of triangle (a, b, c),
// not clamped: ray differentials may land outside the triangle.
Eigen::Vector3f PlaneBarycentric(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& q) {
  const Vec3f v0 = b - a, v1 = c - a, v2 = q - a;
  const float d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1);
  const float d20 = v2.dot(v0), d21 = v2.dot(v1);
  const float denom = d00 * d11 - d01 * d01;
  if (std::abs(denom) < 1e-30f) return {1, 0, 0};
  const float v = (d11 * d20 - d01 * d21) / denom;
  const float w = (d00 * d21 - d01 * d20) / denom;
  return {1.0f - v - w, v, w};
}

// UV where a ray meets the plane of the hit triangle (ray differential).
bool UvOnHitPlane(const Scene& scene, const Hit& hit, const Vec3f& origin, const Vec3f& direction,
                  Vec2f* uv) {
  const Scene::Instance& instance = scene.instances()[hit.instance];
  const TriangleMesh& mesh = scene.mesh(instance.mesh);
  if (!mesh.has_uvs()) return false;
  const Eigen::Vector3i& tri = mesh.triangles[hit.triangle];
  const Vec3f a = instance.world_from_object * mesh.positions[tri[0]];
  const Vec3f b = instance.world_from_object * mesh.positions[tri[1]];
  const Vec3f c = instance.world_from_object * mesh.positions[tri[2]];
  const float denom = hit.geometric_normal.dot(direction);
  if (std::abs(denom) < 1e-8f) return false;
  const float t = hit.geometric_normal.dot(a - origin) / denom;
  const Eigen::Vector3f bary = PlaneBarycentric(a, b, c, origin + t * direction);
  *uv = bary[0] * mesh.uvs[tri[0]] + bary[1] * mesh.uvs[tri[1]] + bary[2] * mesh.uvs[tri[2]];
  return true;
}

void StrataFor(int spp, int* nx, int* ny) {
  int x = static_cast<int>(std::sqrt(static_cast<double>(spp)));
  while (spp % x != 0) --x;
  *nx = x;
  *ny = spp / x;
}

}  // namespace

Image RenderResult::Combined() const {
  std::vector<const Image*> parts = {&radiance, &alpha, &uv, &uv_derivatives, &position, &normal, &depth, &object_id};
  std::vector<std::string> names;
  for (const Image* part : parts) {
    for (const auto& name : part->channel_names()) names.push_back(name);
  }
  Image combined(radiance.width(), radiance.height(), names);
  const int total = combined.channels();
  for (size_t i = 0; i < radiance.pixel_count(); ++i) {
    int offset = 0;
    for (const Image* part : parts) {
      const int n = part->channels();
      for (int c = 0; c < n; ++c) combined.data()[i * total + offset + c] = part->data()[i * n + c];
      offset += n;
    }
  }
  return combined;
}

RenderResult RenderImage(const Scene& scene, const Camera& camera, const RenderOptions& options,
                         const RenderProgress& progress) {
  options.Check();
  camera.intrinsics().Check();
  const int width = camera.intrinsics().width, height = camera.intrinsics().height;
  RenderResult result;
  result.radiance = Image(width, height, std::vector<std::string>{"R", "G", "B"});
  result.alpha = Image(width, height, std::vector<std::string>{"A"});
  result.uv = Image(width, height, std::vector<std::string>{"u", "v"});
  result.uv_derivatives = Image(width, height, std::vector<std::string>{"dudx", "dvdx", "dudy", "dvdy"});
  result.position = Image(width, height, std::vector<std::string>{"P.X", "P.Y", "P.Z"});
  result.normal = Image(width, height, std::vector<std::string>{"N.X", "N.Y", "N.Z"});
  result.depth = Image(width, height, std::vector<std::string>{"Z"});
  result.object_id = Image(width, height, std::vector<std::string>{"id"}, -1.0f);

  const Vec3f centre = camera.Center().cast<float>();
  const Rigid3& cam_from_world = camera.cam_from_world();
  auto is_alpha_object = [&](int id) {
    if (id < 0) return false;
    if (options.alpha_object_ids.empty()) return true;
    return std::find(options.alpha_object_ids.begin(), options.alpha_object_ids.end(), id) !=
           options.alpha_object_ids.end();
  };
  auto ray_through = [&](double x, double y) { return camera.PixelToWorldRay({x, y}).cast<float>().eval(); };

  int strata_x = 1, strata_y = 1;
  StrataFor(options.samples_per_pixel, &strata_x, &strata_y);
  std::atomic<int> rows_done{0};
  std::mutex progress_mutex;

  tbb::parallel_for(tbb::blocked_range<int>(0, height, 1), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      for (int x = 0; x < width; ++x) {
        const uint64_t pixel_index = static_cast<uint64_t>(y) * width + x;
        Rng rng(MixBits(options.seed * 0x9E3779B97F4A7C15ULL + pixel_index), pixel_index);
        Rgb sum = Rgb::Zero();
        int alpha_hits = 0;
        for (int s = 0; s < options.samples_per_pixel; ++s) {
          const Vec2f u = rng.Uniform2();
          const float jx = ((s % strata_x) + u.x()) / strata_x;
          const float jy = ((s / strata_x) + u.y()) / strata_y;
          float dx = jx - 0.5f, dy = jy - 0.5f;
          if (options.filter == PixelFilter::kGaussian) {
            // Box-Muller on the stratified point: filter importance sampling.
            const float r = options.gaussian_stddev_px * std::sqrt(-2.0f * std::log(std::max(1.0f - jx, 1e-7f)));
            dx = r * std::cos(2.0f * kPi * jy);
            dy = r * std::sin(2.0f * kPi * jy);
          }
          const Vec3f direction = ray_through(x + dx, y + dy);
          Hit first;
          if (scene.Intersect(centre, direction, 0.0f, kInfinity, &first) && is_alpha_object(first.object_id)) {
            ++alpha_hits;
          }
          sum += TraceRadiance(scene, centre, direction, options, rng);
        }
        const Rgb mean = sum / static_cast<float>(options.samples_per_pixel);
        for (int c = 0; c < 3; ++c) result.radiance.at(x, y, c) = mean[c];
        result.alpha.at(x, y, 0) = static_cast<float>(alpha_hits) / options.samples_per_pixel;

        // Geometry AOVs from the pixel-centre ray.
        const Vec3f direction = ray_through(x, y);
        Hit hit;
        if (scene.Intersect(centre, direction, 0.0f, kInfinity, &hit) && hit.quad_light < 0) {
          for (int c = 0; c < 3; ++c) {
            result.position.at(x, y, c) = hit.position[c];
            result.normal.at(x, y, c) = hit.shading_normal[c];
          }
          result.depth.at(x, y, 0) = static_cast<float>((cam_from_world * hit.position.cast<double>()).z());
          result.object_id.at(x, y, 0) = static_cast<float>(hit.object_id);
          result.uv.at(x, y, 0) = hit.uv.x();
          result.uv.at(x, y, 1) = hit.uv.y();
          Vec2f uv_x, uv_y;
          if (UvOnHitPlane(scene, hit, centre, ray_through(x + 1, y), &uv_x) &&
              UvOnHitPlane(scene, hit, centre, ray_through(x, y + 1), &uv_y)) {
            result.uv_derivatives.at(x, y, 0) = uv_x.x() - hit.uv.x();
            result.uv_derivatives.at(x, y, 1) = uv_x.y() - hit.uv.y();
            result.uv_derivatives.at(x, y, 2) = uv_y.x() - hit.uv.x();
            result.uv_derivatives.at(x, y, 3) = uv_y.y() - hit.uv.y();
          }
        }
      }
      const int done = ++rows_done;
      if (progress) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        progress(done, height);
      }
    }
  });
  return result;
}

}  // namespace relit::render
