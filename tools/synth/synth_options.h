// Options of relit-synth: preset, size, seed and every knob of the simulated
// capture. Defaults depend on the size ("tiny", "demo", "full"): build with
// SynthOptions::ForSize(), then ReadOptions() a YAML file on top (the field
// table in synth_options.cc; unknown keys are errors; SynthOptions::FromFile
// does both, the size from the file if need be), then CheckOptions().
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/board.h"
#include "core/option_fields.h"

namespace relit::synth {

struct SynthOptions {
  std::string preset = "spot";       // spot | bunny | spheres | mesh
  std::string mesh_path;             // preset "mesh": OBJ or PLY file
  double mesh_height_m = 0.12;       // preset "mesh": scaled to this height
  bool mesh_y_up = true;             // preset "mesh": false if the file is Z-up
  std::string size = "tiny";         // tiny | demo | full
  uint64_t seed = 1;
  std::string out;                   // output directory (required)
  std::string assets_dir;            // empty = compiled-in tools/synth/assets
  bool geometry_pass = false;        // also render geometry.mp4 under soft ambient light
  bool truth_only = false;           // write truth.json and meshes, render nothing
  bool eval_only = false;            // render the evaluation set (and truth.json), no videos
  // Per phone: frames of the board alone (object removed, room light) at
  // varied tilts and distances, written to board_clip/<phone>/ as PNGs for
  // calib's lens calibration (intrinsics.*_board_images). 0 = none.
  int board_clip_frames = 0;

  // Video and rendering.
  int width_px = 320;
  int height_px = 240;
  int fps = 30;
  int frames_per_video = 30;
  int samples_per_pixel = 4;
  int max_depth = 3;                 // path length in bounces
  int crf = 14;
  int display_rotation_deg = 0;      // phone-style rotate metadata on the MP4s
  // Phone L differs from phone V like a second real phone: its own frame
  // count (0 = frames_per_video), frame rate (0 = fps; 29.97, 59.94, 23.976
  // mean 30000/1001, ...) and audio sample rate. Phone V's audio rate is
  // view_audio_rate_hz.
  int light_frames_per_video = 0;
  double light_fps = 0.0;
  int view_audio_rate_hz = 48000;
  int light_audio_rate_hz = 48000;
  // More ways two real phones differ. Phone L's frame size (0 = width_px /
  // height_px) and display rotation (-1 = display_rotation_deg, which is
  // phone V's). Where each audio track starts in its file relative to the
  // first video frame (seconds; negative = audio starts first).
  int light_width_px = 0;
  int light_height_px = 0;
  int light_display_rotation_deg = -1;
  double view_audio_start_s = 0.0;
  double light_audio_start_s = 0.0;
  // Rolling shutter: time from the first to the last sensor row (0 = global
  // shutter); the frame's timestamp and truth pose are the middle row's.
  double view_rolling_shutter_s = 0.0;
  double light_rolling_shutter_s = 0.0;
  // Auto-exposure drift: the exposure follows exposure * (1 + a sin(2 pi t /
  // duration + phase)) over each video, a = this relative amplitude.
  double view_exposure_drift = 0.0;
  double light_exposure_drift = 0.0;
  // A flash shadow over most of the board in phone V's frames (as a real
  // flash casts behind the object and the person holding phone L): board
  // and table pixels farther than view_flash_shadow_edge_m beyond the board
  // centre, along the flash's horizontal direction, get their radiance
  // times view_flash_shadow_factor (1 = no such shadow). Not traced: a mask
  // on the rendered radiance, see docs/synthetic.md.
  double view_flash_shadow_factor = 1.0;
  double view_flash_shadow_edge_m = 0.0;

  // Phone lenses: horizontal field of view, principal point offset (fraction
  // of the image size) and OpenCV distortion (k1, k2, p1, p2, k3).
  double view_hfov_deg = 67.0;
  double light_hfov_deg = 70.0;
  std::vector<double> view_principal_offset = {0.012, -0.008};
  std::vector<double> light_principal_offset = {-0.009, 0.010};
  std::vector<double> view_distortion = {0.09, -0.03, 0.0004, -0.0003, 0.0};
  std::vector<double> light_distortion = {0.06, 0.01, -0.0002, 0.0005, 0.0};

  // Hand-held paths.
  double distance_min_m = 0.3;
  double distance_max_m = 0.7;
  double elevation_min_deg = 15.0;
  double elevation_max_deg = 70.0;
  double view_turns = 1.0;           // azimuth revolutions of phone V over its video
  int elevation_bands = 1;           // phone V's rings, lowest first (view_turns / bands turns each)
  double light_speed_ratio = 3.0;    // phone L's azimuth rate / phone V's
  double roll_max_deg = 10.0;
  double jitter_m = 0.0015;
  double jitter_deg = 0.3;
  double aim_error_m = 0.01;

  // Flash (phone L's torch): offset from the lens in phone L's camera frame.
  std::vector<double> flash_offset_cam_m = {0.01, 0.0, 0.0};
  double flash_intensity_w_per_sr = 0.9;
  double geometry_ambient_scale = 1.0;  // radiance scale of the geometry-pass environment

  // Sensor.
  double exposure = 1.0;
  double full_well_e = 800.0;
  double read_noise_e = 3.0;

  // Audio: |offset| between the two recordings' starts is drawn uniformly in
  // [min, max] with a random sign.
  double audio_offset_min_s = 0.2;
  double audio_offset_max_s = 3.0;
  int clap_count = 4;

  // Evaluation set.
  int eval_views = 3;                // extrapolation views, >= eval_min_angle_deg from phone V's path
  int eval_interpolation_views = 0;  // views on phone V's path between its frames (DNL's held-out frames)
  int eval_samples_per_pixel = 16;
  // Environment-lit eval images: the map's light arrives from everywhere,
  // and at the same samples their truth is 5-10 dB noisier than under a
  // point or directional light. 0 = eval_samples_per_pixel.
  int eval_environment_samples_per_pixel = 0;
  // Outside the box where the foreground projects (board, table: shown in
  // eval's images, never scored) eval images take this many samples.
  int eval_background_samples_per_pixel = 4;
  // Every eval image the mean of two independent renders at half the
  // samples, one of them written beside it, so eval can measure the truth's
  // own noise floor at no extra render cost (relight.md, "Evaluation").
  bool eval_noise_halves = true;
  int eval_point_lights = 2;
  int eval_directional_lights = 2;
  int envmap_width_px = 512;
  double eval_min_angle_deg = 10.0;  // held-out views stay this far from every phone-V view

  BoardSpec board;

  // Defaults for a size; throws relit::Error for an unknown size.
  static SynthOptions ForSize(const std::string& size);
  // A --config file ("" = none) read on the defaults of a size: `size` when
  // not empty, else the file's own `size:`, else `default_size`.
  static SynthOptions FromFile(const std::string& config, const std::string& size, const std::string& default_size);
  static const OptionFields<SynthOptions>& Fields();
  void Check() const;  // across fields; ranges and choices: CheckOptions
  // Path samples per pixel of an eval image under a light of `light_type`
  // ("point", "directional", "environment"): eval_environment_samples_per_pixel
  // resolved.
  int EvalSamplesPerPixel(const std::string& light_type) const {
    return light_type == "environment" && eval_environment_samples_per_pixel > 0 ? eval_environment_samples_per_pixel
                                                                                 : eval_samples_per_pixel;
  }

  double duration_s() const { return static_cast<double>(frames_per_video) / fps; }
  int LightFrames() const { return light_frames_per_video > 0 ? light_frames_per_video : frames_per_video; }
  double LightFps() const { return ExactFps(light_fps > 0 ? light_fps : fps); }
  double light_duration_s() const { return LightFrames() / LightFps(); }
  int LightWidth() const { return light_width_px > 0 ? light_width_px : width_px; }
  int LightHeight() const { return light_height_px > 0 ? light_height_px : height_px; }
  int LightRotation() const {
    return light_display_rotation_deg >= 0 ? light_display_rotation_deg : display_rotation_deg;
  }
  // 29.97 -> 30000/1001 (NTSC-style rates), other rates unchanged.
  static double ExactFps(double fps);

 private:
  void CheckLenses() const;
};

std::vector<std::string> SizeNames();

}  // namespace relit::synth
