// Where relit-bench-reconstruct's proxy accuracy is lost: the Chamfer
// distance to the GT mesh after each step of the dense proxy path, and a
// copy of a workspace with ground-truth cameras (to separate calibration
// error from stereo and fusion error).
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "core/render/mesh.h"

namespace relit::bench {

// Chamfer distance (both one-sided means, their p90, and the symmetric mean,
// also as % of the GT bounding-box diagonal) to `gt` of: the fused oriented
// points, the raw Poisson surface, the cleaned mesh before remeshing, after
// remeshing + decimation, after the small-handle cut, and the workspace's
// own proxy. Reads W/reconstruct/proxy_points/ and the stage's options
// from W/reconstruct/run.json; the cleanup runs again here.
nlohmann::json ProxyBreakdown(const std::string& workspace, const render::TriangleMesh& gt, int samples);

// Writes `out`/calib/cameras.json with the true lens and true poses of
// every phone V frame of `workspace` (light frames are dropped) and the
// frames undistorted with the true lens to the workspace's own pinhole
// camera; `out`/capture links to the workspace's capture. relit-reconstruct
// then runs on `out` exactly as on a calibrated workspace.
void WriteTruthCameraWorkspace(const std::string& workspace, const std::string& synth, const std::string& out);

}  // namespace relit::bench
