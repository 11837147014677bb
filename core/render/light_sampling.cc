#include "core/render/light_sampling.h"

#include <algorithm>
#include <cmath>

namespace relit::render {

Vec3f OffsetOrigin(const Vec3f& p, const Vec3f& ng, const Vec3f& direction) {
  const float scale = 1e-4f * (1.0f + p.cwiseAbs().maxCoeff());
  return p + (ng.dot(direction) > 0 ? scale : -scale) * ng;
}

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

float QuadLightPdf(const QuadLight& light, const Vec3f& wi, float t) {
  const float cos_light = -wi.dot(light.Normal());
  if (cos_light <= 0) return 0;
  return t * t / (light.Area() * cos_light);
}


bool Unoccluded(const Scene& scene, const Vec3f& p, const Vec3f& ng, const LightSample& s) {
  const Vec3f origin = OffsetOrigin(p, ng, s.wi);
  if (std::isinf(s.distance)) return !scene.Occluded(origin, s.wi, 0.0f, kInfinity);
  // Aim from the offset origin so the ray stops short of an emitter's surface.
  const Vec3f to_light = p + s.distance * s.wi - origin;
  return !scene.Occluded(origin, to_light.normalized(), 0.0f, to_light.norm() * (1.0f - 1e-4f));
}

Rgb EscapedRadiance(const Scene& scene, const Vec3f& direction, float bsdf_pdf) {
  if (!scene.environment().valid()) return Rgb::Zero();
  const Rgb le = scene.environment().Eval(direction);
  if (bsdf_pdf < 0) return le;
  const float light_pdf = scene.environment().Pdf(direction) / scene.light_count();
  return le * PowerHeuristic(bsdf_pdf, light_pdf);
}

Rgb EmitterRadiance(const Scene& scene, const Hit& hit, const Vec3f& direction, float bsdf_pdf) {
  const QuadLight& light = scene.quad_lights()[hit.quad_light];
  if (direction.dot(light.Normal()) >= 0) return Rgb::Zero();  // back side does not emit
  if (bsdf_pdf < 0) return light.radiance;
  const float light_pdf = QuadLightPdf(light, direction, hit.t) / scene.light_count();
  return light.radiance * PowerHeuristic(bsdf_pdf, light_pdf);
}

}  // namespace relit::render
