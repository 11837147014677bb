#include "tools/synth/capture_plan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/error.h"
#include "core/render/sampling.h"
#include "tools/synth/audio.h"

namespace relit::synth {

namespace {

constexpr double kDegToRad = M_PI / 180.0;

enum Stream : uint64_t {
  kViewPath = 1, kLightPath, kGeometryPath, kOffset, kClaps, kEval, kLightDirection, kSun,
  kBoardClip, kEvalInterpolation, kViewExposure, kLightExposure,
};

// Smallest angle between a unit direction and any of `directions` (pi for none).
double NearestAngleRad(const Eigen::Vector3d& direction, const std::vector<Eigen::Vector3d>& directions) {
  double nearest = M_PI;
  for (const Eigen::Vector3d& d : directions) {
    nearest = std::min(nearest, std::acos(std::clamp(direction.dot(d), -1.0, 1.0)));
  }
  return nearest;
}

std::string Numbered(const std::string& prefix, int i) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%s_%02d", prefix.c_str(), i);
  return buffer;
}

HandheldPathParams PathParams(const SynthOptions& o, const SynthScene& scene, double turns,
                              double duration_s, double speed, int elevation_bands = 1) {
  HandheldPathParams p;
  p.elevation_bands = elevation_bands;
  p.band_period_s = duration_s / elevation_bands;
  p.target_world = scene.target_world;
  p.distance_min_m = o.distance_min_m;
  p.distance_max_m = o.distance_max_m;
  p.elevation_min_rad = o.elevation_min_deg * kDegToRad;
  p.elevation_max_rad = o.elevation_max_deg * kDegToRad;
  p.azimuth_rate_rev_per_s = turns / duration_s;
  p.drift_period_s = duration_s / speed;
  p.roll_max_rad = o.roll_max_deg * kDegToRad;
  p.jitter_m = o.jitter_m;
  p.jitter_rad = o.jitter_deg * kDegToRad;
  p.aim_error_m = o.aim_error_m;
  return p;
}

// The flash at time t_s: phone L's path carries it at flash_offset_cam_m.
Eigen::Vector3d FlashAt(const HandheldPath* flash_path, const Eigen::Vector3d& flash_offset_cam_m, double t_s) {
  if (flash_path == nullptr) return Eigen::Vector3d::Zero();
  return flash_path->CamFromWorld(t_s).Inverse() * flash_offset_cam_m;
}

// Rows are read top to bottom over the readout; the middle row at t_common_s.
std::vector<RowBand> RollingShutterBands(int height_px, double readout_s, double t_common_s,
                                         const HandheldPath& path, const HandheldPath* flash_path,
                                         const Eigen::Vector3d& flash_offset_cam_m) {
  std::vector<RowBand> bands;
  if (readout_s <= 0) return bands;
  const int count = std::min(kRollingShutterBands, height_px);
  for (int b = 0; b < count; ++b) {
    RowBand band;
    band.row_begin = b * height_px / count;
    band.row_end = (b + 1) * height_px / count;
    const double middle_row = 0.5 * (band.row_begin + band.row_end);
    band.t_common_s = t_common_s + (middle_row / height_px - 0.5) * readout_s;
    band.cam_from_world = path.CamFromWorld(band.t_common_s);
    band.light_position_world = FlashAt(flash_path, flash_offset_cam_m, band.t_common_s);
    bands.push_back(band);
  }
  return bands;
}

VideoPlan SampleVideo(const std::string& name, const std::string& phone, const std::string& lighting,
                      const Intrinsics& intrinsics, const HandheldPath& path,
                      const HandheldPath* flash_path, const Eigen::Vector3d& flash_offset_cam_m,
                      double start_common_s, const RecordingParams& recording) {
  VideoPlan video;
  video.name = name;
  video.phone = phone;
  video.lighting = lighting;
  video.intrinsics = intrinsics;
  video.start_common_s = start_common_s;
  video.fps = recording.fps;
  video.audio_rate_hz = recording.audio_rate_hz;
  video.audio_start_s = recording.audio_start_s;
  video.rolling_shutter_s = recording.rolling_shutter_s;
  video.exposure_drift = recording.exposure_drift;
  video.display_rotation_deg = recording.display_rotation_deg;
  uint64_t exposure_state = recording.exposure_seed;
  const double exposure_phase = 2 * M_PI * UniformFromState(&exposure_state);
  const double duration_s = recording.frame_count / recording.fps;
  for (int i = 0; i < recording.frame_count; ++i) {
    FramePlan frame;
    frame.index = i;
    frame.t_own_s = static_cast<double>(i) / recording.fps;
    frame.t_common_s = start_common_s + frame.t_own_s;
    frame.cam_from_world = path.CamFromWorld(frame.t_common_s);
    frame.light_position_world = FlashAt(flash_path, flash_offset_cam_m, frame.t_common_s);
    frame.exposure_scale =
        1 + recording.exposure_drift * std::sin(2 * M_PI * frame.t_own_s / duration_s + exposure_phase);
    frame.bands = RollingShutterBands(intrinsics.height, recording.rolling_shutter_s, frame.t_common_s,
                                      path, flash_path, flash_offset_cam_m);
    video.frames.push_back(frame);
  }
  return video;
}

// A lens-calibration clip as people film one: the board (object removed)
// filling most of the frame, tilted 10-50 degrees towards every side, turned
// about the optical axis, aimed at varied points so that corners reach every
// part of the image, including the distorted edges.
VideoPlan BoardClip(const std::string& phone, const Intrinsics& intrinsics, const BoardSpec& board,
                    int frame_count, uint64_t seed) {
  VideoPlan video;
  video.name = phone + "_board_clip";
  video.phone = phone;
  video.lighting = "environment";
  video.intrinsics = intrinsics;
  uint64_t state = seed;
  const double half_width = 0.5 * board.width_m(), half_height = 0.5 * board.height_m();
  // Distance at which the board's longer side spans the image width.
  const double fill_distance_m = half_width * intrinsics.fx / (0.5 * intrinsics.width);
  constexpr double kGoldenAngle = 2.39996322972865332;
  for (int i = 0; i < frame_count; ++i) {
    const double tilt = (10 + 40 * UniformFromState(&state)) * kDegToRad;
    const double azimuth = i * kGoldenAngle + 0.3 * UniformFromState(&state);
    const double distance = fill_distance_m * (0.75 + 0.45 * UniformFromState(&state));
    const Eigen::Vector3d aim(half_width * 0.5 * (2 * UniformFromState(&state) - 1),
                              half_height * 0.5 * (2 * UniformFromState(&state) - 1), 0.0);
    const Eigen::Vector3d direction(std::sin(tilt) * std::cos(azimuth), std::sin(tilt) * std::sin(azimuth),
                                    std::cos(tilt));
    const double roll = (2 * UniformFromState(&state) - 1) * 35 * kDegToRad;
    const Eigen::Vector3d up(std::cos(azimuth + M_PI + roll), std::sin(azimuth + M_PI + roll), 0.0);
    FramePlan frame;
    frame.index = i;
    frame.cam_from_world = LookAt(aim + distance * direction, aim, up);
    video.frames.push_back(frame);
  }
  return video;
}

}  // namespace

uint64_t SubSeed(uint64_t seed, uint64_t stream) {
  return render::MixBits(render::MixBits(seed + 0x51ed) ^ (stream * 0x9e3779b97f4a7c15ULL));
}

Intrinsics PhoneIntrinsics(int width_px, int height_px, double hfov_deg,
                           const std::vector<double>& principal_offset,
                           const std::vector<double>& distortion) {
  Intrinsics k = Intrinsics::FromFov(width_px, height_px, hfov_deg * kDegToRad);
  k.cx += principal_offset.at(0) * width_px;
  k.cy += principal_offset.at(1) * height_px;
  k.distortion.k1 = distortion.at(0);
  k.distortion.k2 = distortion.at(1);
  k.distortion.p1 = distortion.at(2);
  k.distortion.p2 = distortion.at(3);
  k.distortion.k3 = distortion.at(4);
  k.Check();
  return k;
}

CapturePlan MakeCapturePlan(const SynthOptions& o, const SynthScene& scene) {
  CheckOptions(o);
  CapturePlan plan;
  plan.view_intrinsics = PhoneIntrinsics(o.width_px, o.height_px, o.view_hfov_deg,
                                         o.view_principal_offset, o.view_distortion);
  plan.light_intrinsics = PhoneIntrinsics(o.LightWidth(), o.LightHeight(), o.light_hfov_deg,
                                          o.light_principal_offset, o.light_distortion);
  plan.eval_intrinsics = plan.view_intrinsics.WithoutDistortion();
  plan.flash_offset_cam_m = Eigen::Vector3d(o.flash_offset_cam_m[0], o.flash_offset_cam_m[1],
                                            o.flash_offset_cam_m[2]);

  // Offset: magnitude uniform in [min, max], random sign; microsecond grid.
  uint64_t state = SubSeed(o.seed, kOffset);
  const double magnitude =
      o.audio_offset_min_s + (o.audio_offset_max_s - o.audio_offset_min_s) * UniformFromState(&state);
  const double sign = UniformFromState(&state) < 0.5 ? -1.0 : 1.0;
  plan.light_start_offset_s = std::round(sign * magnitude * 1e6) / 1e6;

  // Claps where both phones record audio, away from the overlap's ends.
  const double duration = o.duration_s();
  const double overlap_begin = std::max(o.view_audio_start_s, plan.light_start_offset_s + o.light_audio_start_s);
  const double overlap_end = std::min(o.view_audio_start_s + duration,
                                      plan.light_start_offset_s + o.light_audio_start_s + o.light_duration_s());
  RELIT_REQUIRE(overlap_end - overlap_begin >= 0.3, "the two phones' audio tracks overlap by only ",
                overlap_end - overlap_begin, " s: lower audio_offset_max_s or the *_audio_start_s, or "
                "raise frames_per_video");
  const double margin = 0.1 * (overlap_end - overlap_begin);
  plan.clap_times_common_s = PickClapTimes(overlap_begin + margin, overlap_end - margin, o.clap_count,
                                           0.05, SubSeed(o.seed, kClaps));

  // Paths. Phone L circles light_speed_ratio times faster, in a random direction.
  uint64_t direction_state = SubSeed(o.seed, kLightDirection);
  const double light_sign = UniformFromState(&direction_state) < 0.5 ? -1.0 : 1.0;
  plan.view_path = PathParams(o, scene, o.view_turns, duration, 1.0, o.elevation_bands);
  plan.light_path = PathParams(o, scene, light_sign * o.light_speed_ratio * o.view_turns, duration,
                               std::max(1.0, o.light_speed_ratio));
  plan.geometry_path =
      PathParams(o, scene, std::max(1.0, std::abs(o.view_turns)), duration, 1.0, o.elevation_bands);
  const HandheldPath view_path(plan.view_path, SubSeed(o.seed, kViewPath));
  const HandheldPath light_path(plan.light_path, SubSeed(o.seed, kLightPath));
  const RecordingParams view_recording{o.frames_per_video, static_cast<double>(o.fps), o.view_audio_rate_hz,
                                       o.view_audio_start_s, o.view_rolling_shutter_s, o.view_exposure_drift,
                                       SubSeed(o.seed, kViewExposure), o.display_rotation_deg};
  const RecordingParams light_recording{o.LightFrames(), o.LightFps(), o.light_audio_rate_hz,
                                        o.light_audio_start_s, o.light_rolling_shutter_s,
                                        o.light_exposure_drift, SubSeed(o.seed, kLightExposure),
                                        o.LightRotation()};
  plan.view = SampleVideo("view", "view", "flash", plan.view_intrinsics, view_path, &light_path,
                          plan.flash_offset_cam_m, 0.0, view_recording);
  plan.light = SampleVideo("light", "light", "flash", plan.light_intrinsics, light_path, &light_path,
                           plan.flash_offset_cam_m, plan.light_start_offset_s, light_recording);
  if (o.geometry_pass) {
    const HandheldPath geometry_path(plan.geometry_path, SubSeed(o.seed, kGeometryPath));
    plan.geometry = SampleVideo("geometry", "view", "environment", plan.view_intrinsics,
                                geometry_path, nullptr, Eigen::Vector3d::Zero(), 0.0, view_recording);
  }

  if (o.board_clip_frames > 0) {
    plan.view_board_clip = BoardClip("view", plan.view_intrinsics, o.board, o.board_clip_frames,
                                     SubSeed(o.seed, kBoardClip));
    plan.light_board_clip = BoardClip("light", plan.light_intrinsics, o.board, o.board_clip_frames,
                                      SubSeed(o.seed, kBoardClip + 100));
    // Exported from the phone as it shows them: turned like its videos.
    plan.view_board_clip.display_rotation_deg = o.display_rotation_deg;
    plan.light_board_clip.display_rotation_deg = o.LightRotation();
  }

  // Held-out evaluation views: away from every phone-V view direction.
  std::vector<Eigen::Vector3d> training_directions;
  for (const FramePlan& f : plan.view.frames) {
    training_directions.push_back(
        (f.cam_from_world.Inverse().translation - scene.target_world).normalized());
  }
  uint64_t eval_state = SubSeed(o.seed, kEval);
  const double min_angle_rad = o.eval_min_angle_deg * kDegToRad;
  for (int v = 0; v < o.eval_views; ++v) {
    bool placed = false;
    for (int attempt = 0; attempt < 20000 && !placed; ++attempt) {
      const double azimuth = 2 * M_PI * UniformFromState(&eval_state);
      const double elevation =
          (o.elevation_min_deg + (o.elevation_max_deg - o.elevation_min_deg) * UniformFromState(&eval_state)) *
          kDegToRad;
      const double distance = o.distance_min_m + (o.distance_max_m - o.distance_min_m) *
                                                     (0.25 + 0.5 * UniformFromState(&eval_state));
      const Eigen::Vector3d direction(std::cos(elevation) * std::cos(azimuth),
                                      std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
      double nearest = NearestAngleRad(direction, training_directions);
      for (const EvalView& other : plan.eval_views) {  // spread the held-out views too
        const Eigen::Vector3d d = (other.cam_from_world.Inverse().translation - scene.target_world).normalized();
        if (std::acos(std::clamp(direction.dot(d), -1.0, 1.0)) < min_angle_rad) nearest = -1;
      }
      if (nearest < min_angle_rad) continue;
      EvalView view;
      view.name = Numbered("view", v);
      view.cam_from_world = LookAt(scene.target_world + distance * direction, scene.target_world,
                                   Eigen::Vector3d::UnitZ());
      view.min_angle_to_training_rad = nearest;
      plan.eval_views.push_back(view);
      placed = true;
    }
    RELIT_REQUIRE(placed, "cannot place held-out evaluation view ", v, " at least ",
                  o.eval_min_angle_deg, " deg away from the phone-V path: lower eval_min_angle_deg");
  }
  // Interpolation views: phone V's own path at random times between its
  // frames, as DNL evaluates on held-out frames of the capture, and only
  // while phone L records too: a phone V frame without flash frames around
  // it is not part of the capture (relit-capture drops it). Their own seed
  // stream, after the extrapolation views, leaves those and the lights as
  // they were.
  uint64_t interpolation_state = SubSeed(o.seed, kEvalInterpolation);
  double usable_begin_s = 0, usable_end_s = 0;
  if (!plan.view.frames.empty() && !plan.light.frames.empty()) {
    usable_begin_s = std::max(plan.view.frames.front().t_common_s, plan.light.frames.front().t_common_s);
    usable_end_s = std::min(plan.view.frames.back().t_common_s, plan.light.frames.back().t_common_s);
  }
  RELIT_REQUIRE(o.eval_interpolation_views == 0 || usable_end_s > usable_begin_s,
                "the two phones' videos do not overlap (no phone V frame has flash frames around it): lower "
                "audio_offset_max_s or raise frames_per_video");
  for (int v = 0; v < o.eval_interpolation_views; ++v) {
    const double t_s = usable_begin_s + (usable_end_s - usable_begin_s) * UniformFromState(&interpolation_state);
    EvalView view;
    view.name = Numbered("interp", v);
    view.set = "interpolation";
    view.cam_from_world = view_path.CamFromWorld(t_s);
    const Eigen::Vector3d direction = (view.cam_from_world.Inverse().translation - scene.target_world).normalized();
    view.min_angle_to_training_rad = NearestAngleRad(direction, training_directions);
    plan.eval_views.push_back(view);
  }

  // Evaluation lights.
  for (int i = 0; i < o.eval_point_lights; ++i) {
    const double azimuth = 2 * M_PI * UniformFromState(&eval_state);
    const double elevation = (20 + 55 * UniformFromState(&eval_state)) * kDegToRad;
    const double distance = 0.4 + 0.3 * UniformFromState(&eval_state);
    EvalLight light;
    light.name = Numbered("point", i);
    light.type = "point";
    light.position_world = scene.target_world + distance * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                                                           std::cos(elevation) * std::sin(azimuth),
                                                                           std::sin(elevation));
    light.rgb = Eigen::Vector3d::Constant(o.flash_intensity_w_per_sr);
    plan.eval_lights.push_back(light);
  }
  for (int i = 0; i < o.eval_directional_lights; ++i) {
    const double azimuth = 2 * M_PI * UniformFromState(&eval_state);
    const double elevation = (25 + 45 * UniformFromState(&eval_state)) * kDegToRad;
    EvalLight light;
    light.name = Numbered("directional", i);
    light.type = "directional";
    light.direction_to_light = Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                               std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    light.rgb = Eigen::Vector3d(2.0, 1.9, 1.75);
    plan.eval_lights.push_back(light);
  }
  uint64_t sun_state = SubSeed(o.seed, kSun);
  plan.sun_elevation_rad = (30 + 25 * UniformFromState(&sun_state)) * kDegToRad;
  plan.sun_azimuth_rad = 2 * M_PI * UniformFromState(&sun_state);
  for (const char* map : {"sky", "studio"}) {
    EvalLight light;
    light.name = std::string("env_") + map;
    light.type = "environment";
    light.envmap = map;
    plan.eval_lights.push_back(light);
  }
  return plan;
}

}  // namespace relit::synth
