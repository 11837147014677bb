// Radiance cues of Deferred Neural Lighting: the proxy geometry rendered, with
// global illumination, as if made entirely of each of a few basis materials.
//
// All basis materials are traced along one shared path per sample: the camera
// ray, its primary hit and every light sample are shared, directions are drawn
// from the equal-weight mixture of the basis BSDFs, and each basis keeps its
// own path throughput (f_k cos / p_mixture). MIS weights use the mixture pdf,
// which keeps every cue unbiased while paying for one path instead of five.
#pragma once

#include <string>
#include <vector>

#include "core/render/path_tracer.h"

namespace relit::render {

struct CueBasis {
  std::string name;
  BsdfParams bsdf;
};

// DNL's basis: Lambert (albedo 1) and Cook-Torrance GGX with alpha 0.02,
// 0.05, 0.13 and 0.34 (relit roughness = GGX alpha), specular multiplier 1
// and F0 = 1, i.e. no Fresnel dimming: the cues span reflectance shapes and
// the network learns each texel's scale and Fresnel behaviour.
std::vector<CueBasis> DefaultCueBasis();

// Channel names "cue<k>.R", "cue<k>.G", "cue<k>.B" for k = 0..count-1.
std::vector<std::string> CueChannelNames(int count);

// Adds one sample of every basis cue (3 floats per basis) to `out`.
// `primary` is the camera ray's first intersection (nullptr = miss). With
// `delta_direct_out` set, the direct light of point and directional lights
// at the primary hit goes there instead of `out` (same layout).
void TraceCues(const Scene& scene, const std::vector<CueBasis>& basis, const Vec3f& origin,
               const Vec3f& direction, const Hit* primary, const RenderOptions& options, Rng& rng,
               float* out, float* delta_direct_out = nullptr);

// Renders all cues for one camera. RenderResult::radiance holds 3 x basis
// channels; alpha, uv, uv derivatives and the other AOVs are as RenderImage's.
// The scene's materials are ignored, except on context objects: with
// options.alpha_object_ids set, any other object keeps its own material in
// every cue (light it bounces onto the proxy, shadows it casts) and a camera
// ray that hits one first adds nothing (background).
RenderResult RenderCues(const Scene& scene, const Camera& camera, const RenderOptions& options,
                        const std::vector<CueBasis>& basis = DefaultCueBasis(),
                        const RenderProgress& progress = {});

// As RenderCues, with the direct light of point and directional lights at
// the primary hit kept apart: radiance holds 2 x 3 x basis channels, the
// cues without that light (CueChannelNames), then that light alone
// ("direct." + the same names); their sum is RenderCues' radiance. The
// apart part has no noise but the pixel footprint's, so a denoiser can
// leave it (and its hard shadow edges) alone.
RenderResult RenderCuesDeltaDirectApart(const Scene& scene, const Camera& camera, const RenderOptions& options,
                                        const std::vector<CueBasis>& basis = DefaultCueBasis(),
                                        const RenderProgress& progress = {});

}  // namespace relit::render
