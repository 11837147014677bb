// relit-reconstruct: the reconstruct stage. Reads W/calib/cameras.json (the
// undistorted phone V frames and their cameras), builds the proxy mesh (dense
// stereo + Poisson, the sparse fallback, or a user-supplied mesh; see
// docs/reconstruct.md), cleans it (crop above
// the board, floaters, holes, manifold, outward, remeshing), gives it a UV
// atlas, projects it into every phone V frame for a trimap and solves a
// closed-form alpha matte per frame. Writes W/reconstruct/: proxy.obj (+ .mtl),
// proxy.json, atlas_preview.png, mattes/, trimaps/, reconstruct_report.json,
// reconstruct.log and run.json.
#pragma once

#include <string>

#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct {

struct ReconstructSummary {
  std::string out_dir;
  int faces = 0;
  int charts = 0;
  double atlas_utilisation = 0;
  int mattes = 0;
  int skipped_frames = 0;   // phone V frames where the proxy is not visible
  double seconds = 0;
};

// Runs the stage with checked options; W/reconstruct appears complete or not
// at all. Throws relit::Error with a one-line message on bad input.
ReconstructSummary RunReconstructImpl(const ReconstructOptions& options);

// Command line: --workspace W [--config reconstruct.yaml] [--mesh user.obj]
// [--proxy-method dense|sparse|mesh] [--log-level L], then RunReconstructImpl.
int RunReconstruct(int argc, char** argv);

}  // namespace relit::reconstruct
