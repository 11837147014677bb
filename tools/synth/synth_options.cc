#include "tools/synth/synth_options.h"

#include <algorithm>
#include <cmath>

#include "core/workspace.h"
#include "core/error.h"
#include "tools/synth/scene.h"

namespace relit::synth {

double SynthOptions::ExactFps(double fps) {
  const double ntsc = std::round(fps * 1.001) / 1.001;
  const bool integer = std::abs(fps - std::round(fps)) < 1e-9;
  return !integer && std::abs(fps - ntsc) < 0.01 ? ntsc : fps;
}

std::vector<std::string> SizeNames() { return {"tiny", "demo", "full"}; }

namespace {

// tiny and demo film with two phones that differ as real ones do (issue 25),
// so the tests exercise what the pipeline must not assume: phone L has its
// own frame size, 29.97 fps with 10% more frames, 44.1 kHz audio starting
// after its first frame (phone V's before), a drifting auto-exposure, and
// both read their rows over 1 ms. The readout is short because these sizes
// move the phones 3x faster than a real capture; phone V keeps a fixed
// exposure (relight assumes one exposure for its training frames).
void TwoDifferentPhones(SynthOptions* o, int light_width_px, int light_height_px) {
  o->light_width_px = light_width_px;
  o->light_height_px = light_height_px;
  o->light_fps = 29.97;
  o->light_frames_per_video = o->frames_per_video * 11 / 10;
  o->light_audio_rate_hz = 44100;
  o->view_audio_start_s = -0.021;
  o->light_audio_start_s = 0.034;
  o->view_rolling_shutter_s = 0.001;
  o->light_rolling_shutter_s = 0.001;
  o->light_exposure_drift = 0.15;
}

}  // namespace

SynthOptions SynthOptions::ForSize(const std::string& size) {
  SynthOptions o;
  o.size = size;
  if (size == "tiny") {
    // Small enough for the test suite (< 1 min on 2 cores), yet the board
    // must stay detectable: nearer cameras than the real 0.3-0.7 m.
    o.width_px = 320;
    o.height_px = 240;
    o.frames_per_video = 30;
    o.samples_per_pixel = 4;
    o.max_depth = 3;
    o.distance_min_m = 0.28;
    o.distance_max_m = 0.42;
    o.view_turns = 0.5;
    o.audio_offset_min_s = 0.2;
    o.audio_offset_max_s = 0.5;
    // The flash is nearer than in the real 0.3-0.7 m capture: dimmer, same exposure.
    o.flash_intensity_w_per_sr = 0.45;
    // AprilTag 36h11 markers are ~2.5 px per bit at 320x240 and fail to
    // decode; 4x4 markers (6 bits across with the border) are found reliably.
    o.board.dictionary = "DICT_4X4_50";
    o.clap_count = 3;
    o.eval_views = 2;
    TwoDifferentPhones(&o, 352, 264);
    o.eval_interpolation_views = 1;
    o.eval_samples_per_pixel = 8;
    o.eval_point_lights = 2;
    o.eval_directional_lights = 1;
    o.envmap_width_px = 256;
  } else if (size == "demo") {
    // <= 5 min on 2 cores. At 480x360 the 36h11 markers of the default board
    // are ~3 px per bit at 0.5 m and mostly fail to decode; 4x4 markers work.
    o.width_px = 480;
    o.height_px = 360;
    o.samples_per_pixel = 4;
    o.max_depth = 3;
    o.distance_min_m = 0.3;
    o.distance_max_m = 0.55;
    o.flash_intensity_w_per_sr = 0.7;
    // Two rings, one low and one high, each a whole turn, as a capture guide
    // asks for (docs/capture.md): 8 s of video, of which capture keeps 120
    // frames (pipeline.yaml), as many as the one-turn 4-s demo had.
    o.frames_per_video = 240;
    o.view_turns = 2.0;
    o.elevation_bands = 2;
    // A real capture lasts minutes and loses a few seconds at its ends to
    // the phones' start offset; 3 s of a 4-s video would lose most of the
    // turn (phone V frames without flash frames are dropped), so the demo's
    // offset stays small, as in tiny.
    o.audio_offset_min_s = 0.2;
    o.audio_offset_max_s = 0.5;
    // 3 + 3 views, of which the demo's eval scores 2 + 2 (pipeline.yaml
    // max_views). The lights are drawn after the extrapolation views, from
    // the same stream: with 2 views the eval set's lights would change.
    o.eval_views = 3;
    o.eval_interpolation_views = 3;
    // 16 spp left the environment-lit truth's own noise floor at 23 dB
    // (point 33, directional 35; eval's truth_noise_floor). 128 (two halves
    // of 64) cost what 64 and a 64-spp noise twin did and halve the truth's
    // noise variance (floor under the maps ~30.5 dB).
    o.eval_samples_per_pixel = 128;
    o.envmap_width_px = 512;
    o.board.dictionary = "DICT_4X4_50";
    TwoDifferentPhones(&o, 512, 384);
  } else if (size == "full") {
    // Phone-like 16:9 frames, large enough for the default AprilTag board
    // across the whole 0.3-0.7 m range.
    o.width_px = 960;
    o.height_px = 540;
    o.frames_per_video = 300;
    o.samples_per_pixel = 16;
    o.max_depth = 6;
    o.view_turns = 1.5;
    o.eval_views = 8;
    o.eval_interpolation_views = 8;
    o.eval_samples_per_pixel = 64;
    o.eval_point_lights = 3;
    o.eval_directional_lights = 3;
    o.envmap_width_px = 1024;
  } else {
    Fail("unknown size '", size, "' (known: tiny, demo, full)");
  }
  return o;
}

SynthOptions SynthOptions::FromFile(const std::string& config, const std::string& size,
                                   const std::string& default_size) {
  std::string chosen_size = size;
  if (chosen_size.empty()) {
    chosen_size = default_size;
    if (!config.empty()) OptionsReader::FromFile(config).Read("size", &chosen_size);
  }
  SynthOptions options = ForSize(chosen_size);
  if (!config.empty()) {
    OptionsReader reader = OptionsReader::FromFile(config);
    ReadOptions(reader, &options);
  }
  options.size = chosen_size;
  return options;
}

RELIT_OPTION_FIELDS(SynthOptions,
    .Add("preset", &S::preset, PresetNames(), "the scene (see \"Presets\" in docs/synthetic.md)")
    .Add("mesh_path", &S::mesh_path, "preset mesh: OBJ or PLY file (`--mesh`)")
    .Add("mesh_height_m", &S::mesh_height_m, 0.01, 0.5, "preset mesh: scaled to this height, metres")
    .Add("mesh_y_up", &S::mesh_y_up, "preset mesh: false if the file is Z-up")
    .Add("size", &S::size, SizeNames(), "the defaults of every other key (`--size`)")
    .Add("seed", &S::seed, "random seed of paths, noise, audio and eval views (`--seed`)")
    .Add("out", &S::out, "output folder (`--out`)")
    .Add("assets_dir", &S::assets_dir, "meshes and textures; empty = the compiled-in tools/synth/assets")
    .Add("geometry_pass", &S::geometry_pass, "also render geometry.mp4 under soft ambient light")
    .Add("truth_only", &S::truth_only, "write truth.json and meshes, render nothing")
    .Add("eval_only", &S::eval_only, "render the evaluation set (and truth.json), no videos")
    .Add("board_clip_frames", &S::board_clip_frames, 0, 1000,
         "per phone: board-only frames for lens calibration in board_clip/<phone>/ (`--board-clip`)")
    .Add("width_px", &S::width_px, 16, 8192, "phone V's frame width; even")
    .Add("height_px", &S::height_px, 16, 8192, "phone V's frame height; even")
    .Add("fps", &S::fps, 1, 240, "phone V's frame rate")
    .Add("frames_per_video", &S::frames_per_video, 2, 100000, "phone V's frames")
    .Add("samples_per_pixel", &S::samples_per_pixel, 1, 1 << 16, "path samples per video pixel")
    .Add("max_depth", &S::max_depth, 1, 64, "path length in bounces")
    .Add("crf", &S::crf, 0, 51, "H.264 quality of the videos")
    .Add("display_rotation_deg", &S::display_rotation_deg,
         "phone-style rotate metadata on the MP4s: 0, 90, 180 or 270")
    .Add("light_frames_per_video", &S::light_frames_per_video, 0, 100000,
         "phone L's frames: 0 (= frames_per_video) or >= 2")
    .Add("light_fps", &S::light_fps, 0.0, 240.0,
         "phone L's frame rate: 0 (= fps) or >= 1; 29.97, 59.94, 23.976 mean 30000/1001, ...")
    .Add("view_audio_rate_hz", &S::view_audio_rate_hz, 8000, 192000, "phone V's audio sample rate")
    .Add("light_audio_rate_hz", &S::light_audio_rate_hz, 8000, 192000, "phone L's audio sample rate")
    .Add("light_width_px", &S::light_width_px, 0, 8192, "phone L's frame width (0 = width_px)")
    .Add("light_height_px", &S::light_height_px, 0, 8192, "phone L's frame height (0 = height_px)")
    .Add("light_display_rotation_deg", &S::light_display_rotation_deg,
         "phone L's rotate metadata (-1 = display_rotation_deg)")
    .Add("view_audio_start_s", &S::view_audio_start_s, -0.5, 0.5,
         "where phone V's audio starts relative to its first frame, s (negative: audio first)")
    .Add("light_audio_start_s", &S::light_audio_start_s, -0.5, 0.5, "the same for phone L")
    .Add("view_rolling_shutter_s", &S::view_rolling_shutter_s, 0.0, 0.1,
         "phone V's readout from the first to the last row, s (0 = global shutter); below 1 / fps")
    .Add("light_rolling_shutter_s", &S::light_rolling_shutter_s, 0.0, 0.1, "the same for phone L")
    .Add("view_exposure_drift", &S::view_exposure_drift, 0.0, 0.5,
         "relative amplitude of phone V's auto-exposure drift over the video")
    .Add("light_exposure_drift", &S::light_exposure_drift, 0.0, 0.5, "the same for phone L")
    .Add("view_flash_shadow_factor", &S::view_flash_shadow_factor, 0.0, 1.0,
         "radiance factor of the flash shadow on the board in phone V's frames (1 = none)")
    .Add("view_flash_shadow_edge_m", &S::view_flash_shadow_edge_m, -1.0, 1.0,
         "the shadow starts this far beyond the board centre along the flash's direction, m")
    .Add("view_hfov_deg", &S::view_hfov_deg, 20.0, 120.0, "phone V's horizontal field of view")
    .Add("light_hfov_deg", &S::light_hfov_deg, 20.0, 120.0, "phone L's horizontal field of view")
    .Add("view_principal_offset", &S::view_principal_offset,
         "phone V's principal point offset, 2 fractions of the image size below 0.2")
    .Add("light_principal_offset", &S::light_principal_offset, "the same for phone L")
    .Add("view_distortion", &S::view_distortion, "phone V's OpenCV distortion: k1, k2, p1, p2, k3")
    .Add("light_distortion", &S::light_distortion, "the same for phone L")
    .Add("distance_min_m", &S::distance_min_m, 0.1, 5.0, "nearest camera distance to the object, m")
    .Add("distance_max_m", &S::distance_max_m, 0.1, 5.0, "farthest camera distance, m")
    .Add("elevation_min_deg", &S::elevation_min_deg, 5.0, 85.0,
         "lowest camera elevation (upper hemisphere, above the table)")
    .Add("elevation_max_deg", &S::elevation_max_deg, 5.0, 85.0, "highest camera elevation")
    .Add("view_turns", &S::view_turns, -20.0, 20.0, "azimuth revolutions of phone V over its video")
    .Add("elevation_bands", &S::elevation_bands, 1, 8,
         "phone V's elevation rings, lowest first, view_turns / elevation_bands turns each (1: one drift "
         "over the whole range)")
    .Add("light_speed_ratio", &S::light_speed_ratio, 0.0, 20.0, "phone L's azimuth rate / phone V's")
    .Add("roll_max_deg", &S::roll_max_deg, 0.0, 45.0, "largest hand roll of the phones")
    .Add("jitter_m", &S::jitter_m, 0.0, 0.02, "hand shake, metres")
    .Add("jitter_deg", &S::jitter_deg, 0.0, 3.0, "hand shake, degrees")
    .Add("aim_error_m", &S::aim_error_m, 0.0, 0.1, "how far the phones aim off the object centre, m")
    .Add("flash_offset_cam_m", &S::flash_offset_cam_m,
         "the flash's offset from phone L's lens in its camera frame: x, y, z within 0.1 m")
    .Add("flash_intensity_w_per_sr", &S::flash_intensity_w_per_sr, 0.0, 1e6, "the flash's intensity")
    .Add("geometry_ambient_scale", &S::geometry_ambient_scale, 0.0, 1e6,
         "radiance scale of the geometry pass's environment")
    .Add("exposure", &S::exposure, "sensor exposure; > 0")
    .Add("full_well_e", &S::full_well_e, 10.0, 1e9, "sensor full well, electrons")
    .Add("read_noise_e", &S::read_noise_e, 0.0, 1e6, "sensor read noise, electrons")
    .Add("audio_offset_min_s", &S::audio_offset_min_s, 0.0, 3600.0,
         "|offset| between the recordings' starts is drawn in [min, max], random sign")
    .Add("audio_offset_max_s", &S::audio_offset_max_s, 0.0, 3600.0,
         "see audio_offset_min_s; leaves >= 0.5 s of overlap")
    .Add("clap_count", &S::clap_count, 1, 100, "claps both phones hear")
    .Add("eval_views", &S::eval_views, 0, 1000,
         "extrapolation views, >= eval_min_angle_deg from phone V's path (`--eval-views`)")
    .Add("eval_interpolation_views", &S::eval_interpolation_views, 0, 1000,
         "views on phone V's path between its frames (DNL's held-out frames)")
    .Add("eval_samples_per_pixel", &S::eval_samples_per_pixel, 1, 1 << 16,
         "path samples per eval pixel in the box where the foreground projects")
    .Add("eval_environment_samples_per_pixel", &S::eval_environment_samples_per_pixel, 0, 1 << 16,
         "path samples per eval pixel of the environment-lit images (their truth is the noisiest); 0 = "
         "eval_samples_per_pixel")
    .Add("eval_background_samples_per_pixel", &S::eval_background_samples_per_pixel, 1, 1 << 16,
         "path samples per eval pixel outside that box (background: shown, never scored)")
    .Add("eval_noise_halves", &S::eval_noise_halves,
         "render every eval image as the mean of two independent halves of its samples and keep one half, for "
         "eval's noise floor of the truth")
    .Add("eval_point_lights", &S::eval_point_lights, 0, 100, "point lights of the eval set")
    .Add("eval_directional_lights", &S::eval_directional_lights, 0, 100, "directional lights of the eval set")
    .Add("envmap_width_px", &S::envmap_width_px, 16, 16384, "width of the eval set's environment maps; even")
    .Add("eval_min_angle_deg", &S::eval_min_angle_deg, 0.0, 90.0,
         "held-out views stay this far from every phone V view")
    .Section("board", &S::board))

void SynthOptions::Check() const {
  RELIT_REQUIRE(preset != "mesh" || !mesh_path.empty(),
                "preset 'mesh' needs mesh_path (--mesh FILE or mesh_path in the YAML file)");
  RELIT_REQUIRE(!out.empty(), "no output directory: pass --out DIR");
  RELIT_REQUIRE(!(truth_only && eval_only),
                "truth_only and eval_only exclude each other (truth_only renders nothing)");
  RELIT_REQUIRE(!eval_only || eval_views > 0,
                "eval_only needs eval_views > 0 (there is nothing else to render)");
  RELIT_REQUIRE(width_px % 2 == 0 && height_px % 2 == 0,
                "width_px and height_px must be even (H.264 yuv420p), got ", width_px, "x", height_px);
  RELIT_REQUIRE(light_frames_per_video == 0 || light_frames_per_video >= 2,
                "light_frames_per_video must be 0 (= frames_per_video) or >= 2, got ",
                light_frames_per_video);
  RELIT_REQUIRE(light_fps == 0 || light_fps >= 1, "light_fps must be 0 (= fps) or in [1, 240], got ", light_fps);
  const auto quarter_turn = [](int deg) { return deg == 0 || deg == 90 || deg == 180 || deg == 270; };
  RELIT_REQUIRE(quarter_turn(display_rotation_deg), "display_rotation_deg must be 0, 90, 180 or 270, got ",
                display_rotation_deg);
  RELIT_REQUIRE(light_display_rotation_deg == -1 || quarter_turn(light_display_rotation_deg),
                "light_display_rotation_deg must be -1 (= display_rotation_deg), 0, 90, 180 or 270, got ",
                light_display_rotation_deg);
  RELIT_REQUIRE((light_width_px == 0) == (light_height_px == 0),
                "light_width_px and light_height_px must both be 0 (= width_px x height_px) or both set, got ",
                light_width_px, "x", light_height_px);
  RELIT_REQUIRE(LightWidth() % 2 == 0 && LightHeight() % 2 == 0 && LightWidth() >= 16 && LightHeight() >= 16,
                "light_width_px and light_height_px must be even and >= 16 (H.264 yuv420p), got ",
                LightWidth(), "x", LightHeight());
  RELIT_REQUIRE(view_rolling_shutter_s < 1.0 / fps && light_rolling_shutter_s < 1.0 / LightFps(),
                "view_rolling_shutter_s and light_rolling_shutter_s must be in [0, 1 / fps) s (the "
                "readout of one frame), got ", view_rolling_shutter_s, " and ", light_rolling_shutter_s);
  CheckLenses();
  RELIT_REQUIRE(distance_min_m <= distance_max_m,
                "camera distances must satisfy 0.1 <= distance_min_m <= distance_max_m <= 5, got [",
                distance_min_m, ", ", distance_max_m, "]");
  RELIT_REQUIRE(elevation_min_deg <= elevation_max_deg,
                "elevations must satisfy 5 <= elevation_min_deg <= elevation_max_deg <= 85 "
                "(upper hemisphere, above the table), got [",
                elevation_min_deg, ", ", elevation_max_deg, "]");
  RELIT_REQUIRE(flash_offset_cam_m.size() == 3, "flash_offset_cam_m must be 3 numbers (x, y, z), got ",
                flash_offset_cam_m.size());
  RELIT_REQUIRE(std::hypot(flash_offset_cam_m[0], flash_offset_cam_m[1], flash_offset_cam_m[2]) <= 0.1,
                "flash_offset_cam_m must be within 0.1 m of the lens");
  RELIT_REQUIRE(exposure > 0, "sensor: exposure must be > 0, got ", exposure);
  RELIT_REQUIRE(audio_offset_min_s <= audio_offset_max_s,
                "audio offsets must satisfy 0 <= audio_offset_min_s <= audio_offset_max_s, got [",
                audio_offset_min_s, ", ", audio_offset_max_s, "]");
  // The two recordings must overlap long enough to hear shared claps.
  RELIT_REQUIRE(audio_offset_max_s <= duration_s() - 0.5,
                "audio_offset_max_s = ", audio_offset_max_s, " s leaves less than 0.5 s of overlap "
                "between the ", duration_s(), " s recordings: lower it or raise frames_per_video");
  RELIT_REQUIRE(envmap_width_px % 2 == 0, "envmap_width_px must be even, got ", envmap_width_px);
}

// Principal offsets and distortion: lists whose length and values the table
// cannot bound.
void SynthOptions::CheckLenses() const {
  for (const auto* offset : {&view_principal_offset, &light_principal_offset}) {
    RELIT_REQUIRE(offset->size() == 2 && std::abs((*offset)[0]) < 0.2 && std::abs((*offset)[1]) < 0.2,
                  "principal offsets must be 2 numbers, fractions of the image size below 0.2");
  }
  for (const auto* d : {&view_distortion, &light_distortion}) {
    RELIT_REQUIRE(d->size() == 5, "distortion must be 5 numbers (k1, k2, p1, p2, k3), got ", d->size());
    RELIT_REQUIRE(std::abs((*d)[0]) < 0.5 && std::abs((*d)[1]) < 0.5 && std::abs((*d)[2]) < 0.05 &&
                      std::abs((*d)[3]) < 0.05 && std::abs((*d)[4]) < 0.5,
                  "distortion coefficients are outside the range of phone lenses "
                  "(|k1|,|k2|,|k3| < 0.5, |p1|,|p2| < 0.05)");
  }
}

}  // namespace relit::synth
