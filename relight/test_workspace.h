// Test fixture: a workspace as the calib and reconstruct stages would leave
// it, built from the synthetic spot scene's ground truth (tiny capture plan):
//   calib/cameras.json      ground-truth phone V poses, pinhole camera
//                           (tiny intrinsics scaled to width_px)
//   calib/lights.json       ground-truth flash positions
//   calib/undistorted/...   linear EXR frames rendered by the path tracer
//                           (scene with board and table, GI)
//   reconstruct/proxy.json  the object's mesh with its UVs, inflated along
//                           the normals by `proxy_offset_m` (a rough proxy),
//                           and ground-truth 16-bit mattes
// Test-only code; real workspaces come from relit-calib/relit-reconstruct.
#pragma once

#include <string>

#include "relight/learn_options.h"

namespace relit::relight::testing {

struct TestWorkspaceOptions {
  int frames = 24;              // phone V frames, spread over the capture
  int width_px = 160;           // image width (height keeps the tiny aspect)
  int samples_per_pixel = 16;
  double proxy_offset_m = 0.002;
};

// The model the relight tests and the learning bench train: ngf 16, 3
// blocks, a 128² texture with 4 channels per basis, so that a few hundred
// steps take a minute on 2 cores.
ModelOptions SmallModel();

// Creates (replacing) the workspace in `dir`.
void MakeTestWorkspace(const std::string& dir, const TestWorkspaceOptions& options);

// truth.json (relit-synth's writer) for the test workspace's capture plan in
// `dir`, eval intrinsics scaled to width_px x height_px. With
// `render_images`, the eval set is path-traced as relit-synth does (board and
// table, 16 spp); otherwise 1x1 placeholders. Returns the truth.json path.
std::string WriteTestTruth(const std::string& dir, bool render_images, int width_px, int height_px);

}  // namespace relit::relight::testing
