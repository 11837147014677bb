// `relit-relight cues`: radiance cues of every phone V frame that has a
// flash position, rendered on the proxy mesh under that frame's flash.
//
// Reads W/calib/cameras.json, W/calib/lights.json, W/reconstruct/proxy.json
// (and its mesh); writes W/relight/cues/ = cues.json + NNNNNN.exr (channels
// in cue_frames.h) + run.json. Frames are rendered into
// W/relight/.cues.partial/ first; an interrupted run with the same inputs and
// options continues there (finished frames are kept), and the folder is only
// renamed to cues/ once every frame is done. With cues.secondary_material
// fitted the frames are rendered with the basis first (.cues.partial/basis/),
// fitted (proxy_cue_weights.exr, kept: a resumed run fits only when it is
// missing) and rendered again with the proxy wearing that fit past the
// primary hit (stage_options.h).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/camera.h"
#include "relight/cue_frames.h"
#include "relight/stage_options.h"
#include "relight/support_plane.h"

namespace relit {
class RunRecord;
}

namespace relit::relight {

struct CueFrameRecord {
  std::string name;               // phone V frame, e.g. "view/000012"
  std::string file;               // cue EXR, relative to the workspace
  Rigid3 cam_from_world;
  Eigen::Vector3d light_position_m = Eigen::Vector3d::Zero();
  bool light_reliable = true;     // calib's verdict on the flash position
};

struct CuesFile {
  static constexpr const char* kKind = "cues";
  static constexpr int kVersion = 1;
  Intrinsics camera;              // undistorted pinhole phone V camera
  std::string mesh;               // proxy mesh used, relative to the workspace
  std::string normal_map;         // its normal map, relative to the workspace; "" (or absent) = none
  // The proxy's fitted cue weights past the primary hit (cues.secondary_material
  // fitted), relative to the workspace; "" (or absent) = the basis.
  std::string cue_weights;
  double flash_intensity = 1;     // W/sr of the point light the cues assume
  int samples_per_pixel = 0;
  int max_depth = 0;
  CueFormat format;               // "input"/"bases"; absent in older files = the default
  SupportPlane support_plane;     // context geometry of the cue scene; absent in older files = none
  std::vector<CueFrameRecord> frames;
};
CuesFile ReadCuesFile(const std::string& path);

// How relit-capture linearised phone V's video (capture.json
// inputs.view.transfer_used: srgb, gamma2.2, hlg, pq); "" without a
// capture.json (a workspace not made by relit-capture, e.g. test fixtures).
std::string CaptureTransfer(const std::string& workspace_root);
void WriteCuesFile(const std::string& path, const CuesFile& file);

struct CueStageSummary {
  int frames_rendered = 0;        // renders (secondary_material fitted: both renderings)
  int frames_reused = 0;          // kept from an interrupted run
};

CueStageSummary RunCueStage(const std::string& workspace, const CueStageOptions& options,
                            RunRecord& record);

// How the stage renders the `index`-th frame of cues.json: the options'
// samples, bounces and denoising, a seed of its own derived from
// options.seed (each frame's noise independent and reproducible).
CueRenderSettings CueFrameRenderSettings(const CueStageOptions& options, size_t index);

// 64-bit FNV-1a of a file's bytes (inputs fingerprint for resuming).
uint64_t HashFile(const std::string& path);
// The same hash of a string's bytes.
uint64_t HashString(const std::string& bytes);

}  // namespace relit::relight
