// Everything relit-synth decides before rendering: phone intrinsics, the
// hand-held paths sampled at every frame, the flash position, the time offset
// between the two recordings, the clap times and the evaluation set. Fully
// determined by (options, seed); truth.json is written from it.
//
// Time convention (also in truth.json): t_common = t_view = t_light +
// light_start_offset_s. Frame i of a phone's video is at time i / fps on that
// phone's own clock (each phone its own fps and frame count), so phone V's
// frame i is at t_common = i / fps_V and phone L's frame j at
// t_common = j / fps_L + light_start_offset_s. A positive
// offset means phone L started recording later than phone V.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/camera.h"
#include "tools/synth/scene.h"
#include "tools/synth/synth_options.h"
#include "tools/synth/trajectory.h"

namespace relit::synth {

// Rows [row_begin, row_end) of a rolling-shutter frame, read at their own
// instant: the camera and the flash where they were then.
struct RowBand {
  int row_begin = 0, row_end = 0;
  double t_common_s = 0;
  Rigid3 cam_from_world;
  Eigen::Vector3d light_position_world = Eigen::Vector3d::Zero();
};

struct FramePlan {
  int index = 0;
  double t_own_s = 0;      // on the recording phone's clock (middle row with a rolling shutter)
  double t_common_s = 0;   // on the common (= phone V) clock
  Rigid3 cam_from_world;
  Eigen::Vector3d light_position_world = Eigen::Vector3d::Zero();  // flash (when lit by it)
  double exposure_scale = 1;  // auto-exposure drift: the sensor's exposure times this
  std::vector<RowBand> bands; // rolling shutter; empty = global shutter
};

// How one phone records: frame count and rate, audio, shutter, exposure.
struct RecordingParams {
  int frame_count = 0;
  double fps = 30;
  int audio_rate_hz = 48000;
  double audio_start_s = 0;       // audio track start relative to the first frame, own clock
  double rolling_shutter_s = 0;   // first to last row
  double exposure_drift = 0;      // relative amplitude of the auto-exposure drift
  uint64_t exposure_seed = 0;     // its phase
  int display_rotation_deg = 0;
};

struct VideoPlan {
  std::string name;        // "view", "light", "geometry"
  std::string phone;       // "view" or "light"
  std::string lighting;    // "flash" or "environment"
  Intrinsics intrinsics;
  double start_common_s = 0;  // common time of frame 0 (geometry: its own session)
  double fps = 30;            // exact (29.97 is 30000/1001): frame i at t_own = i / fps
  int audio_rate_hz = 48000;
  double audio_start_s = 0;   // audio track start relative to frame 0 in the file (own clock)
  double rolling_shutter_s = 0;
  double exposure_drift = 0;
  int display_rotation_deg = 0;  // clockwise "rotate" metadata; pixels stay as rendered
  double duration_s() const { return static_cast<double>(frames.size()) / fps; }
  // Presentation time of frame 0 in the MP4: the encoder delays the video
  // when the audio starts first, so the file's timeline starts at 0.
  double first_frame_pts_s() const { return audio_start_s < 0 ? -audio_start_s : 0.0; }
  std::vector<FramePlan> frames;
};

struct EvalLight {
  std::string name;        // e.g. "point_00", "directional_01", "env_sky"
  std::string type;        // "point", "directional", "environment"
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();     // point
  Eigen::Vector3d direction_to_light = Eigen::Vector3d::UnitZ(); // directional
  Eigen::Vector3d rgb = Eigen::Vector3d::Ones();  // W/sr (point), irradiance (directional), scale (env)
  std::string envmap;      // "sky" / "studio" for environment lights
};

struct EvalView {
  std::string name;        // "view_00", ...
  Rigid3 cam_from_world;
  double min_angle_to_training_rad = 0;  // to the nearest phone-V view direction
  // "extrapolation": away from every phone-V view (eval_min_angle_deg);
  // "interpolation": on phone V's own path between its frames.
  std::string set = "extrapolation";
};

struct CapturePlan {
  Intrinsics view_intrinsics, light_intrinsics;
  Intrinsics eval_intrinsics;  // undistorted pinhole
  Eigen::Vector3d flash_offset_cam_m = Eigen::Vector3d::Zero();
  double light_start_offset_s = 0;
  std::vector<double> clap_times_common_s;
  double sun_elevation_rad = 0, sun_azimuth_rad = 0;
  VideoPlan view, light, geometry;  // geometry.frames empty unless requested
  // Board-only lens-calibration clips (empty unless board_clip_frames > 0);
  // their frames' times are meaningless (a separate session).
  VideoPlan view_board_clip, light_board_clip;
  std::vector<EvalView> eval_views;
  std::vector<EvalLight> eval_lights;
  HandheldPathParams view_path, light_path, geometry_path;
};

// Deterministic sub-seeds: one stream per purpose.
uint64_t SubSeed(uint64_t seed, uint64_t stream);

Intrinsics PhoneIntrinsics(int width_px, int height_px, double hfov_deg,
                           const std::vector<double>& principal_offset,
                           const std::vector<double>& distortion);

// Rolling-shutter bands of a frame: kRollingShutterBands bands (fewer for
// short frames), the middle row at frame.t_common_s.
constexpr int kRollingShutterBands = 32;

CapturePlan MakeCapturePlan(const SynthOptions& options, const SynthScene& scene);

}  // namespace relit::synth
