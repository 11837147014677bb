// The residual model's starting point: its cue regression (texture channels
// 0..2 of each basis, model.h) set to the per-texel least-squares fit of the
// training frames, the cues-only baseline's solution (cues_baseline.h) at the
// texture's own resolution. Training then starts from what the cues alone
// explain instead of from random texels, and the networks learn only what
// the regression misses.
#pragma once

#include <vector>

#include "relight/cue_texture_fit.h"
#include "relight/cues_baseline.h"
#include "relight/model.h"

namespace relit::relight {

struct WarmStartResult {
  int64_t texels = 0;  // all texels of level 0
  // The smooth fit's statistics; the per-texel fit fills only pixels and
  // texels_seen.
  CueFitStats stats;
};

// Fits on every pixel with matte >= 0.5 and proxy coverage >= 0.5 of
// `frames` (Batch tensors with targets) and writes the weights into
// `model`'s texture: the smooth fit (cue_texture_fit.h, `fit`) or, with
// model.cue_fit per_texel, the cues-only baseline's per-texel fit whose
// ridge pulls texels seen by few pixels towards the global fit.
// The smooth fit aligns each frame to the fit (CueFitOptions::align_rounds)
// and shifts the frames' targets and mattes the same way, so the networks
// train on the aligned images. Requires the residual variant.
WarmStartResult WarmStartCueRegression(DnlModel& model, std::vector<Batch>& frames, const CueFitOptions& fit,
                                       double per_texel_ridge = CuesOnlyBaseline::kDefaultRidge);

}  // namespace relit::relight
