// Edge-aware filtering of path-traced radiance cues, guided by the render's
// own geometry AOVs (a cross-bilateral filter, as the first stage of SVGF,
// Schied et al. 2017, and of most real-time path-tracing denoisers).
//
// A radiance cue is the proxy rendered in one uniform basis material, so it
// holds no texture: within one object, pixels whose surfaces face the same
// way at the same depth see nearly the same light. Under an environment map
// at eval's 128 paths per pixel the sharp GGX cues stay visibly noisy, and
// the relit image inherits the noise as speckle
// (docs/notes/relight-fidelity-2026-11-29c.md). Averaging each pixel with
// its neighbours that lie on the same object, with a similar shading normal
// and a similar camera depth, removes most of that noise while keeping the
// silhouette, creases and depth edges. A point or directional light's
// direct light is exact and carries hard shadow edges: relight renders it
// apart (RenderCuesDeltaDirectApart) and filters only the rest.
#pragma once

#include <vector>

#include "core/image.h"
#include "core/render/cue_renderer.h"
#include "core/render/path_tracer.h"

namespace relit::render {

struct CueDenoiseOptions {
  int radius_px = 3;              // window (2 r + 1)^2
  double spatial_sigma_px = 2.0;  // Gaussian falloff with pixel distance
  double normal_sigma = 0.15;     // Gaussian in |n_p - n_q| (unit shading normals), for a Lambert cue
  double depth_sigma = 0.01;      // Gaussian in |z_p - z_q| / z_p (relative camera depth)
};

// Per RGB triple of `radiance`, the normal sigma that suits its basis: a
// glossy lobe of GGX alpha a reflects a part of the map about 2a wide, so
// neighbours whose normals differ by more than that see another part of it
// (a sun's glint would be smeared). Lambert's cosine lobe takes
// options.normal_sigma; GGX alpha a takes normal_sigma x min(1, 2 a).
std::vector<double> CueNormalSigmas(const std::vector<CueBasis>& basis, const CueDenoiseOptions& options = {});

// Filters every channel of `radiance` (the cue channels of `aovs`' render,
// premultiplied by coverage as the renderer writes them) with weights from
// `aovs`' object id, normal, depth and alpha. A pixel whose centre ray hit
// nothing is returned unchanged; neighbours are averaged as unpremultiplied
// values (radiance / alpha) and the result is premultiplied by the pixel's
// own alpha again, so partly covered silhouette pixels keep their coverage.
// `normal_sigmas` holds one sigma per RGB triple (CueNormalSigmas); empty =
// options.normal_sigma for every channel.
Image DenoiseCues(const RenderResult& aovs, const Image& radiance, const CueDenoiseOptions& options = {},
                  const std::vector<double>& normal_sigmas = {});

}  // namespace relit::render
