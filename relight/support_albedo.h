// The support plane's albedo, measured on the capture itself. The support
// plane (support_plane.h) puts the board and the table the object stands on
// into the cue scene so the cues hold the flash's bounce off them and the
// object's reflections of them. What lies there is not known in advance: the
// table's colour, and on the board whatever covers the print (a coaster, a
// turntable, a cloth under the object). Each phone V frame shows the plane
// under the calibrated flash: where a pixel sees it lit directly, its
// radiance is s x albedo x cos(theta) / (pi r^2) with s the flash's unknown
// scale (and the exposure). The white paper, whose albedo is assumed
// (cues.paper_albedo), gives s frame by frame (a median: what covers part of
// the print does not pull it); the table pixels then give the table's albedo
// per channel, and the board's pixels an albedo map of the board's quad.
// Medians throughout, so the object's shadow edges, highlights on the plane
// and sensor noise do not pull them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/camera.h"
#include "core/image.h"
#include "core/render/scene.h"
#include "relight/support_plane.h"

namespace relit::relight {

struct SupportAlbedoFrame {
  Camera camera;               // the undistorted phone V camera of the frame
  Eigen::Vector3d light_position_m;
  std::string image_path;      // its linear image (calib/view_linear)
};

// Used when the frames do not show enough lit table (a grey, as a desk).
constexpr double kDefaultTableAlbedo = 0.2;

struct SupportAlbedoOptions {
  int max_frames = 24;            // evenly spaced; 0 = all
  int pixel_stride = 2;           // every n-th pixel in x and y
  double saturation_level = 0.9;  // brighter pixels are clipped: not measured
  double min_cosine = 0.25;       // flash and camera at least this far above the plane
  int min_paper_pixels = 50;      // per frame, to measure the flash scale
  int min_table_pixels = 200;     // in all, else no estimate
  double board_texel_m = 0.001;   // texel of the board's albedo map; 0 = no map
  int min_texel_samples = 3;      // fewer: the texel keeps the print's albedo
};

struct SupportAlbedoEstimate {
  bool found = false;
  Eigen::Vector3d table_albedo = Eigen::Vector3d::Zero();  // linear RGB in [0, 1]
  int frames_used = 0;
  // The median over the frames used of each frame's flash scale per channel:
  // a linear image value per unit of the cue light on albedo 1 (zero
  // without a frame), which turns fitted cue weights into reflectances.
  Eigen::Vector3d flash_scale = Eigen::Vector3d::Zero();
  int64_t paper_pixels = 0, table_pixels = 0, board_pixels = 0;
  std::string reason;  // why there is no estimate (found == false)
  // The board quad's albedo (linear RGB, rows from the print's top, as
  // SupportPlane::albedo_map): measured texels, the print elsewhere. Empty
  // when board_texel_m is 0 or no frame had lit paper.
  Image board_albedo;
  double board_measured_fraction = 0;  // of its texels
};

// `scene` is the cue scene with the support plane as printed (no albedo map,
// any table albedo: only geometry and the print are read). Frames without
// enough lit paper are skipped.
SupportAlbedoEstimate EstimateSupportAlbedo(const render::Scene& scene, const SupportPlane& plane,
                                            const std::vector<SupportAlbedoFrame>& frames,
                                            const SupportAlbedoOptions& options = {});

}  // namespace relit::relight
