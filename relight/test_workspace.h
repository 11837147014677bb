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

namespace relit::relight::testing {

struct TestWorkspaceOptions {
  int frames = 24;              // phone V frames, spread over the capture
  int width_px = 160;           // image width (height keeps the tiny aspect)
  int samples_per_pixel = 16;
  double proxy_offset_m = 0.002;
};

// Creates (replacing) the workspace in `dir`.
void MakeTestWorkspace(const std::string& dir, const TestWorkspaceOptions& options);

}  // namespace relit::relight::testing
