// The table's albedo, measured on the capture itself. The support plane
// (support_plane.h) puts the board and the table the object stands on into
// the cue scene so the cues hold the flash's bounce off them; the board's
// print is known, the table is not. Each phone V frame shows both under the
// calibrated flash: where a pixel sees the plane lit directly, its radiance
// is s x albedo x cos(theta) / (pi r^2) with s the flash's unknown scale
// (and the exposure). The white paper, whose albedo is assumed
// (cues.paper_albedo), gives s frame by frame; the table pixels then give
// its albedo per channel (medians, so the object's shadow edges, the
// table's highlights and sensor noise do not pull it).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/camera.h"
#include "core/render/scene.h"
#include "relight/support_plane.h"

namespace relit::relight {

struct TableAlbedoFrame {
  Camera camera;               // the undistorted phone V camera of the frame
  Eigen::Vector3d light_position_m;
  std::string image_path;      // its linear image (calib/view_linear)
};

// Used when the frames do not show enough lit table (a grey, as a desk).
constexpr double kDefaultTableAlbedo = 0.2;

struct TableAlbedoOptions {
  int max_frames = 24;            // evenly spaced; 0 = all
  int pixel_stride = 2;           // every n-th pixel in x and y
  double saturation_level = 0.9;  // brighter pixels are clipped: not measured
  double min_cosine = 0.25;       // flash and camera at least this far above the plane
  int min_paper_pixels = 50;      // per frame, to measure the flash scale
  int min_table_pixels = 200;     // in all, else no estimate
};

struct TableAlbedoEstimate {
  bool found = false;
  Eigen::Vector3d table_albedo = Eigen::Vector3d::Zero();  // linear RGB in [0, 1]
  int frames_used = 0;
  int64_t paper_pixels = 0, table_pixels = 0;
  std::string reason;  // why there is no estimate (found == false)
};

// `scene` is the cue scene with the support plane (any table albedo: only
// geometry and the board's print are read). Frames without enough lit paper
// are skipped.
TableAlbedoEstimate EstimateTableAlbedo(const render::Scene& scene, const SupportPlane& plane,
                                        const std::vector<TableAlbedoFrame>& frames,
                                        const TableAlbedoOptions& options = {});

}  // namespace relit::relight
