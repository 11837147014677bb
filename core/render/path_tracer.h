// Unidirectional path tracer with next-event estimation and multiple
// importance sampling, Russian roulette and per-pixel AOVs.
//
// Deterministic for a given seed regardless of thread count: every pixel
// draws from its own random stream.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/image.h"
#include "core/render/scene.h"

namespace relit::render {

enum class PixelFilter { kBox, kGaussian };

struct RenderOptions {
  int samples_per_pixel = 16;        // stratified over the pixel footprint
  int max_depth = 8;                 // bounces; 1 = direct lighting only
  int russian_roulette_depth = 3;    // start roulette after this many bounces
  uint64_t seed = 0;
  PixelFilter filter = PixelFilter::kBox;
  float gaussian_stddev_px = 0.5f;   // Gaussian filter width, pixels
  bool environment_visible = true;   // camera rays that miss see the env map
  // Objects counted as foreground in the alpha AOV; empty = every object.
  std::vector<int> alpha_object_ids;
  void Check() const;
};

// All outputs of one render. Geometry AOVs come from the ray through the
// pixel centre; radiance and alpha are averaged over all samples.
struct RenderResult {
  Image radiance;        // R,G,B linear (or the integrator's channels)
  Image alpha;           // A: fraction of samples hitting an alpha object
  Image uv;              // u,v (0 where nothing was hit)
  Image uv_derivatives;  // dudx,dvdx,dudy,dvdy per pixel (ray differentials)
  Image position;        // P.X,P.Y,P.Z world metres
  Image normal;          // N.X,N.Y,N.Z world shading normal
  Image depth;           // Z: camera-space z, metres (0 = no hit)
  Image object_id;       // id: object id, -1 = background

  // All AOVs in one multi-channel image with the names above.
  Image Combined() const;
};

// Callback: rows finished so far, total rows.
using RenderProgress = std::function<void(int, int)>;

RenderResult RenderImage(const Scene& scene, const Camera& camera, const RenderOptions& options,
                         const RenderProgress& progress = {});

// Adds one sample's values (as many as channel names) to `out` for a camera
// ray whose first intersection the image loop already found (`primary`,
// nullptr when the ray left the scene); must be thread-safe and draw
// randomness only from `rng`.
using SampleIntegrator = std::function<void(const Vec3f& origin, const Vec3f& direction,
                                            const Hit* primary, Rng& rng, float* out)>;

// The image loop behind RenderImage with a custom integrator: stratified
// pixel samples, per-pixel random streams, alpha and geometry AOVs. The
// integrator's per-pixel mean lands in RenderResult::radiance with the given
// channel names.
RenderResult RenderWithIntegrator(const Scene& scene, const Camera& camera, const RenderOptions& options,
                                  const std::vector<std::string>& channel_names,
                                  const SampleIntegrator& integrator, const RenderProgress& progress = {});

// Radiance arriving along one ray (exposed for tests).
Rgb TraceRadiance(const Scene& scene, const Vec3f& origin, const Vec3f& direction,
                  const RenderOptions& options, Rng& rng);
// The same, continuing from a known first intersection (nullptr = miss).
Rgb TraceRadianceFrom(const Scene& scene, const Vec3f& origin, const Vec3f& direction,
                      const Hit* primary, const RenderOptions& options, Rng& rng);

}  // namespace relit::render
