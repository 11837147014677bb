#include "core/render/path_tracer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "core/render/light_sampling.h"

namespace relit::render {

void RenderOptions::Check() const {
  RELIT_REQUIRE(samples_per_pixel >= 1 && samples_per_pixel <= 1 << 16,
                "samples_per_pixel must be in [1, 65536], got ", samples_per_pixel);
  RELIT_REQUIRE(max_depth >= 1 && max_depth <= 64, "max_depth must be in [1, 64], got ", max_depth);
  RELIT_REQUIRE(russian_roulette_depth >= 1, "russian_roulette_depth must be >= 1");
  RELIT_REQUIRE(gaussian_stddev_px > 0 && gaussian_stddev_px <= 4,
                "gaussian_stddev_px must be in (0, 4] pixels, got ", gaussian_stddev_px);
}


Rgb TraceRadiance(const Scene& scene, const Vec3f& origin, const Vec3f& direction,
                  const RenderOptions& options, Rng& rng) {
  Hit primary;
  const bool found = scene.Intersect(origin, direction.normalized(), 0.0f, kInfinity, &primary);
  return TraceRadianceFrom(scene, origin, direction, found ? &primary : nullptr, options, rng);
}

Rgb TraceRadianceFrom(const Scene& scene, const Vec3f& origin_in, const Vec3f& direction_in,
                      const Hit* primary, const RenderOptions& options, Rng& rng) {
  Rgb radiance = Rgb::Zero();
  Rgb throughput = Rgb::Ones();
  Vec3f origin = origin_in, direction = direction_in.normalized();
  float bsdf_pdf = -1;  // < 0: the ray comes from the camera (no MIS)

  for (int bounce = 0;; ++bounce) {
    Hit hit;
    if (!NextHit(scene, bounce, primary, origin, direction, &hit)) {
      if (bsdf_pdf >= 0 || options.environment_visible) {
        radiance += throughput * EscapedRadiance(scene, direction, bsdf_pdf);
      }
      break;
    }
    if (hit.quad_light >= 0) {
      radiance += throughput * EmitterRadiance(scene, hit, direction, bsdf_pdf);
      break;
    }
    if (bounce >= options.max_depth) break;

    const ShadingPoint shading(hit, direction);
    const Vec3f &ng = shading.ng, &wo = shading.wo;
    const Frame& frame = shading.frame;
    if (wo.z() <= 0) break;
    const BsdfParams bsdf = scene.material(hit.material).At(hit.uv);

    // Next-event estimation.
    LightSample ls;
    float select_pdf = 0;
    if (SampleOneLight(scene, hit.position, rng, &ls, &select_pdf) && ng.dot(ls.wi) > 0) {
      const Vec3f wi = frame.ToLocal(ls.wi);
      const Rgb f = EvalBsdf(bsdf, wo, wi);
      if ((f > 0).any() && Unoccluded(scene, hit.position, ng, ls)) {
        if (ls.delta) {
          radiance += throughput * f * ls.radiance * (wi.z() / select_pdf);
        } else {
          const float light_pdf = select_pdf * ls.pdf;
          const float weight = PowerHeuristic(light_pdf, PdfBsdf(bsdf, wo, wi));
          radiance += throughput * f * ls.radiance * (wi.z() * weight / light_pdf);
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
    bsdf_pdf = bs.pdf;
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
  return RenderWithIntegrator(
      scene, camera, options, {"R", "G", "B"},
      [&](const Vec3f& origin, const Vec3f& direction, const Hit* primary, Rng& rng, float* out) {
        const Rgb l = TraceRadianceFrom(scene, origin, direction, primary, options, rng);
        for (int c = 0; c < 3; ++c) out[c] += l[c];
      },
      progress);
}

RenderResult RenderWithIntegrator(const Scene& scene, const Camera& camera, const RenderOptions& options,
                                  const std::vector<std::string>& channel_names,
                                  const SampleIntegrator& integrator, const RenderProgress& progress) {
  options.Check();
  camera.intrinsics().Check();
  const int width = camera.intrinsics().width, height = camera.intrinsics().height;
  const int channels = static_cast<int>(channel_names.size());
  RenderResult result;
  result.radiance = Image(width, height, channel_names);
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
        // Pixel positions have their own stream so alpha and coverage do not
        // depend on how many numbers the integrator consumed.
        Rng position_rng(MixBits(options.seed * 0xD1B54A32D192ED03ULL + pixel_index), pixel_index + 1);
        float* sum = result.radiance.pixel(x, y);  // accumulated in place, zero-initialised
        int alpha_hits = 0;
        for (int s = 0; s < options.samples_per_pixel; ++s) {
          const Vec2f u = position_rng.Uniform2();
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
          // One primary ray serves both the alpha AOV and the integrator.
          Hit first;
          const bool found = scene.Intersect(centre, direction, 0.0f, kInfinity, &first);
          if (found && is_alpha_object(first.object_id)) ++alpha_hits;
          integrator(centre, direction, found ? &first : nullptr, rng, sum);
        }
        for (int c = 0; c < channels; ++c) sum[c] /= static_cast<float>(options.samples_per_pixel);
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
