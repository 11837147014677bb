// Light sampling and emitter look-ups shared by the path tracer and the
// radiance-cue renderer, so both integrate light the same way.
#pragma once

#include <limits>

#include "core/render/scene.h"

namespace relit::render {

constexpr float kInfinity = std::numeric_limits<float>::infinity();

// Ray origin pushed off the surface along the geometric normal, on the side
// the new ray leaves towards; the push scales with the coordinates' size.
Vec3f OffsetOrigin(const Vec3f& p, const Vec3f& ng, const Vec3f& direction);

struct LightSample {
  Vec3f wi;                       // unit direction towards the light
  float distance = kInfinity;     // to the sampled point; infinite for distant lights
  Rgb radiance = Rgb::Zero();     // incident radiance (irradiance for delta lights)
  float pdf = 0;                  // solid angle; ignored for delta lights
  bool delta = false;
};

// Picks one light uniformly and samples a direction towards it from `p`.
bool SampleOneLight(const Scene& scene, const Vec3f& p, Rng& rng, LightSample* s, float* select_pdf);

// Shadow ray from surface point p (geometric normal ng) towards the sample.
bool Unoccluded(const Scene& scene, const Vec3f& p, const Vec3f& ng, const LightSample& s);

// Solid-angle pdf that SampleOneLight picks direction wi hitting quad light q at distance t.
float QuadLightPdf(const QuadLight& light, const Vec3f& wi, float t);

// The next intersection of a path: the given primary hit at bounce 0
// (nullptr = the camera ray missed), a traced ray afterwards.
inline bool NextHit(const Scene& scene, int bounce, const Hit* primary, const Vec3f& origin,
                    const Vec3f& direction, Hit* hit) {
  if (bounce == 0) {
    if (primary) *hit = *primary;
    return primary != nullptr;
  }
  return scene.Intersect(origin, direction, 0.0f, kInfinity, hit);
}

// Two-sided shading at a hit: the geometric normal and the shading frame
// flipped to the side the ray arrives from, and the outgoing direction in
// that frame (wo.z() <= 0: the shading normal faces away, the path ends).
struct ShadingPoint {
  ShadingPoint(const Hit& hit, const Vec3f& direction) {
    ng = hit.geometric_normal;
    Vec3f ns = hit.shading_normal;
    if (ng.dot(direction) > 0) ng = -ng;
    if (ns.dot(ng) < 0) ns = -ns;
    frame = Frame(ns);
    wo = frame.ToLocal(-direction);
  }
  Vec3f ng;
  Frame frame;
  Vec3f wo;
};

// Emitted radiance seen along `direction` when a ray escapes the scene
// (environment) or hits a quad light, weighted by the power heuristic against
// light sampling unless the ray came from the camera (bsdf_pdf < 0).
Rgb EscapedRadiance(const Scene& scene, const Vec3f& direction, float bsdf_pdf);
Rgb EmitterRadiance(const Scene& scene, const Hit& hit, const Vec3f& direction, float bsdf_pdf);

}  // namespace relit::render
