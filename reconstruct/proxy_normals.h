// Photometric-stereo normal map of the proxy from the flash-lit phone V frames.
//
// The proxy is mm-scale wrong in shape and its normals are 20-50 deg off the
// object's (docs/notes/relight-fidelity-2026-11-26.md): the radiance cues
// shade the wrong surface. Each phone V frame is lit by the flash at a
// calibrated position, so every texel the frames see is observed under many
// light directions. Per texel of the proxy's UV atlas, with l_i the unit
// direction to the flash and r_i its distance for observation i,
//
//   I_i = b . l_i / r_i^2 + c        (b = albedo x normal, c = bounce light)
//
// is fitted by robust least squares (Huber weights) over the observations
// that are lit (shadow ray to the flash on the proxy), unclipped and inside
// the silhouette, with a pull of b towards the proxy's own normal (Tikhonov,
// `prior_weight` x the data's own scale) that keeps poorly lit texels where
// the proxy puts them. The result is written as an object-space normal map
// (float RGB EXR at `resolution_px`, zero where no estimate) that the
// renderers read at the hit's uv (render::Material::normal_map).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/image.h"
#include "core/option_fields.h"
#include "core/render/mesh.h"
#include "core/workspace.h"

namespace relit::reconstruct {

struct NormalMapOptions {
  bool enabled = true;           // needs W/calib/lights.json (the flash positions)
  int resolution_px = 128;       // texels per side (the atlas is packed for atlas.resolution_px)
  int min_observations = 8;      // fewer lit observations: the proxy's normal stays
  double prior_weight = 0.3;     // pull towards the proxy normal, in units of the data's own weight
  double max_angle_deg = 45;     // estimated normals are clamped to this cone around the proxy's
  double min_light_cosine = 0.1;  // observations lit more grazingly (on the proxy) are dropped
  double saturation_level = 0.9;  // linear level at or above which a pixel counts as clipped
  int robust_rounds = 3;         // Huber re-weighting rounds
  // The Lambert model must explain this share of a texel's (weighted)
  // variance, else the proxy's normal stays: glossy and mirror-like
  // surfaces break the model and would get random normals.
  double min_explained_variance = 0.5;
  // The turned normal must cut the residual of the fit with the proxy's
  // normal to this share: a right proxy normal stays right.
  double max_residual_ratio = 0.5;
  static const OptionFields<NormalMapOptions>& Fields();
};

struct NormalMapStats {
  int frames = 0;                 // phone V frames with a flash position used
  long long observations = 0;     // lit, unclipped texel observations
  int texels_seen = 0;            // texels with any observation
  int texels_estimated = 0;       // texels with at least min_observations
  int texels_not_lambert = 0;     // of those, kept the proxy normal (min_explained_variance, max_residual_ratio)
  double median_change_deg = 0;   // estimated vs proxy normal, over estimated texels
  double p90_change_deg = 0;
  double seconds = 0;
  nlohmann::json ToJson() const;
};

// The normal map of `mesh` (the proxy as written, with its per-corner UVs)
// from the phone V `frames` of `cameras` lit by `lights`. Images are read
// from `workspace`/frame.image_linear. Throws relit::Error naming a file.
Image EstimateNormalMap(const std::string& workspace, const CamerasFile& cameras, const LightsFile& lights,
                        const std::vector<const CalibratedFrame*>& frames, const render::TriangleMesh& mesh,
                        const NormalMapOptions& options, NormalMapStats* stats);

}  // namespace relit::reconstruct
