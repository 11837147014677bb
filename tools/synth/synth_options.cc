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
    o.frames_per_video = 120;
    o.samples_per_pixel = 4;
    o.max_depth = 3;
    o.distance_min_m = 0.3;
    o.distance_max_m = 0.55;
    o.flash_intensity_w_per_sr = 0.7;
    o.view_turns = 1.0;
    o.eval_views = 3;
    o.eval_interpolation_views = 3;
    // 16 spp left the environment-lit truth's own noise floor at 23 dB
    // (point 33, directional 35; eval's truth_noise_floor): 4x the samples
    // buy ~6 dB, so scores up to ~24 dB stay 6 dB clear of the truth's noise.
    o.eval_samples_per_pixel = 64;
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

void SynthOptions::Read(OptionsReader& r) {
  r.Read("preset", &preset);
  r.Read("mesh_path", &mesh_path);
  r.Read("mesh_height_m", &mesh_height_m);
  r.Read("mesh_y_up", &mesh_y_up);
  r.Read("size", &size);
  r.Read("seed", &seed);
  r.Read("out", &out);
  r.Read("assets_dir", &assets_dir);
  r.Read("geometry_pass", &geometry_pass);
  r.Read("truth_only", &truth_only);
  r.Read("eval_only", &eval_only);
  r.ReadRange("board_clip_frames", &board_clip_frames, 0, 1000);
  r.ReadRange("width_px", &width_px, 16, 8192);
  r.ReadRange("height_px", &height_px, 16, 8192);
  r.ReadRange("fps", &fps, 1, 240);
  r.ReadRange("frames_per_video", &frames_per_video, 2, 100000);
  r.ReadRange("samples_per_pixel", &samples_per_pixel, 1, 1 << 16);
  r.ReadRange("max_depth", &max_depth, 1, 64);
  r.ReadRange("crf", &crf, 0, 51);
  r.Read("display_rotation_deg", &display_rotation_deg);
  r.ReadRange("light_frames_per_video", &light_frames_per_video, 0, 100000);
  r.ReadRange("light_fps", &light_fps, 0.0, 240.0);
  r.ReadRange("view_audio_rate_hz", &view_audio_rate_hz, 8000, 192000);
  r.ReadRange("light_audio_rate_hz", &light_audio_rate_hz, 8000, 192000);
  r.ReadRange("light_width_px", &light_width_px, 0, 8192);
  r.ReadRange("light_height_px", &light_height_px, 0, 8192);
  r.Read("light_display_rotation_deg", &light_display_rotation_deg);
  r.ReadRange("view_audio_start_s", &view_audio_start_s, -0.5, 0.5);
  r.ReadRange("light_audio_start_s", &light_audio_start_s, -0.5, 0.5);
  r.ReadRange("view_rolling_shutter_s", &view_rolling_shutter_s, 0.0, 0.1);
  r.ReadRange("light_rolling_shutter_s", &light_rolling_shutter_s, 0.0, 0.1);
  r.ReadRange("view_exposure_drift", &view_exposure_drift, 0.0, 0.5);
  r.ReadRange("light_exposure_drift", &light_exposure_drift, 0.0, 0.5);
  r.ReadRange("view_flash_shadow_factor", &view_flash_shadow_factor, 0.0, 1.0);
  r.ReadRange("view_flash_shadow_edge_m", &view_flash_shadow_edge_m, -1.0, 1.0);
  r.ReadRange("view_hfov_deg", &view_hfov_deg, 20.0, 120.0);
  r.ReadRange("light_hfov_deg", &light_hfov_deg, 20.0, 120.0);
  r.Read("view_principal_offset", &view_principal_offset);
  r.Read("light_principal_offset", &light_principal_offset);
  r.Read("view_distortion", &view_distortion);
  r.Read("light_distortion", &light_distortion);
  r.Read("distance_min_m", &distance_min_m);
  r.Read("distance_max_m", &distance_max_m);
  r.Read("elevation_min_deg", &elevation_min_deg);
  r.Read("elevation_max_deg", &elevation_max_deg);
  r.ReadRange("view_turns", &view_turns, -20.0, 20.0);
  r.ReadRange("light_speed_ratio", &light_speed_ratio, 0.0, 20.0);
  r.Read("roll_max_deg", &roll_max_deg);
  r.Read("jitter_m", &jitter_m);
  r.Read("jitter_deg", &jitter_deg);
  r.Read("aim_error_m", &aim_error_m);
  r.Read("flash_offset_cam_m", &flash_offset_cam_m);
  r.ReadRange("flash_intensity_w_per_sr", &flash_intensity_w_per_sr, 0.0, 1e6);
  r.ReadRange("geometry_ambient_scale", &geometry_ambient_scale, 0.0, 1e6);
  r.Read("exposure", &exposure);
  r.Read("full_well_e", &full_well_e);
  r.Read("read_noise_e", &read_noise_e);
  r.Read("audio_offset_min_s", &audio_offset_min_s);
  r.Read("audio_offset_max_s", &audio_offset_max_s);
  r.ReadRange("clap_count", &clap_count, 1, 100);
  r.ReadRange("eval_views", &eval_views, 0, 1000);
  r.ReadRange("eval_interpolation_views", &eval_interpolation_views, 0, 1000);
  r.ReadRange("eval_samples_per_pixel", &eval_samples_per_pixel, 1, 1 << 16);
  r.Read("eval_noise_twin", &eval_noise_twin);
  r.ReadRange("eval_point_lights", &eval_point_lights, 0, 100);
  r.ReadRange("eval_directional_lights", &eval_directional_lights, 0, 100);
  r.ReadRange("envmap_width_px", &envmap_width_px, 16, 16384);
  r.ReadRange("eval_min_angle_deg", &eval_min_angle_deg, 0.0, 90.0);
  OptionsReader board_reader = r.Child("board");
  ReadBoardSpec(board_reader, &board);
  r.Finish();
}

void SynthOptions::Check() const {
  const auto presets = PresetNames();
  RELIT_REQUIRE(std::find(presets.begin(), presets.end(), preset) != presets.end(),
                "unknown preset '", preset, "' (known: spot, bunny, spheres, mesh)");
  RELIT_REQUIRE(preset != "mesh" || !mesh_path.empty(),
                "preset 'mesh' needs mesh_path (--mesh FILE or mesh_path in the YAML file)");
  RELIT_REQUIRE(mesh_height_m > 0.01 && mesh_height_m < 0.5,
                "mesh_height_m must be in (0.01, 0.5) m, got ", mesh_height_m);
  const auto sizes = SizeNames();
  RELIT_REQUIRE(std::find(sizes.begin(), sizes.end(), size) != sizes.end(), "unknown size '",
                size, "' (known: tiny, demo, full)");
  RELIT_REQUIRE(!out.empty(), "no output directory: pass --out DIR");
  RELIT_REQUIRE(!(truth_only && eval_only),
                "truth_only and eval_only exclude each other (truth_only renders nothing)");
  RELIT_REQUIRE(!eval_only || eval_views > 0,
                "eval_only needs eval_views > 0 (there is nothing else to render)");
  RELIT_REQUIRE(width_px % 2 == 0 && height_px % 2 == 0 && width_px >= 16 && height_px >= 16,
                "width_px and height_px must be even and >= 16 (H.264 yuv420p), got ", width_px,
                "x", height_px);
  RELIT_REQUIRE(fps >= 1 && fps <= 240, "fps must be in [1, 240], got ", fps);
  RELIT_REQUIRE(frames_per_video >= 2, "frames_per_video must be >= 2, got ", frames_per_video);
  RELIT_REQUIRE(light_frames_per_video == 0 || light_frames_per_video >= 2,
                "light_frames_per_video must be 0 (= frames_per_video) or >= 2, got ",
                light_frames_per_video);
  RELIT_REQUIRE(light_fps == 0 || (light_fps >= 1 && light_fps <= 240),
                "light_fps must be 0 (= fps) or in [1, 240], got ", light_fps);
  RELIT_REQUIRE(view_audio_rate_hz >= 8000 && light_audio_rate_hz >= 8000 &&
                    view_audio_rate_hz <= 192000 && light_audio_rate_hz <= 192000,
                "view_audio_rate_hz and light_audio_rate_hz must be in [8000, 192000] Hz");
  RELIT_REQUIRE(samples_per_pixel >= 1 && eval_samples_per_pixel >= 1,
                "samples per pixel must be >= 1");
  RELIT_REQUIRE(max_depth >= 1, "max_depth must be >= 1, got ", max_depth);
  RELIT_REQUIRE(crf >= 0 && crf <= 51, "crf must be in [0, 51], got ", crf);
  RELIT_REQUIRE(display_rotation_deg == 0 || display_rotation_deg == 90 ||
                    display_rotation_deg == 180 || display_rotation_deg == 270,
                "display_rotation_deg must be 0, 90, 180 or 270, got ", display_rotation_deg);
  RELIT_REQUIRE(light_display_rotation_deg == -1 || light_display_rotation_deg == 0 ||
                    light_display_rotation_deg == 90 || light_display_rotation_deg == 180 ||
                    light_display_rotation_deg == 270,
                "light_display_rotation_deg must be -1 (= display_rotation_deg), 0, 90, 180 or 270, got ",
                light_display_rotation_deg);
  RELIT_REQUIRE((light_width_px == 0) == (light_height_px == 0),
                "light_width_px and light_height_px must both be 0 (= width_px x height_px) or both set, got ",
                light_width_px, "x", light_height_px);
  RELIT_REQUIRE(LightWidth() % 2 == 0 && LightHeight() % 2 == 0 && LightWidth() >= 16 && LightHeight() >= 16,
                "light_width_px and light_height_px must be even and >= 16 (H.264 yuv420p), got ",
                LightWidth(), "x", LightHeight());
  RELIT_REQUIRE(std::abs(view_audio_start_s) <= 0.5 && std::abs(light_audio_start_s) <= 0.5,
                "view_audio_start_s and light_audio_start_s must be in [-0.5, 0.5] s");
  RELIT_REQUIRE(view_rolling_shutter_s >= 0 && light_rolling_shutter_s >= 0 &&
                    view_rolling_shutter_s < 1.0 / fps && light_rolling_shutter_s < 1.0 / LightFps(),
                "view_rolling_shutter_s and light_rolling_shutter_s must be in [0, 1 / fps) s (the "
                "readout of one frame), got ", view_rolling_shutter_s, " and ", light_rolling_shutter_s);
  RELIT_REQUIRE(view_exposure_drift >= 0 && view_exposure_drift <= 0.5 && light_exposure_drift >= 0 &&
                    light_exposure_drift <= 0.5,
                "view_exposure_drift and light_exposure_drift must be in [0, 0.5] (relative amplitude)");
  RELIT_REQUIRE(view_flash_shadow_factor >= 0 && view_flash_shadow_factor <= 1 &&
                    std::abs(view_flash_shadow_edge_m) <= 1,
                "view_flash_shadow_factor must be in [0, 1] (1 = no shadow) and view_flash_shadow_edge_m "
                "in [-1, 1] m, got ", view_flash_shadow_factor, " and ", view_flash_shadow_edge_m);
  for (const auto* offset : {&view_principal_offset, &light_principal_offset}) {
    RELIT_REQUIRE(offset->size() == 2 && std::abs((*offset)[0]) < 0.2 && std::abs((*offset)[1]) < 0.2,
                  "principal offsets must be 2 numbers, fractions of the image size below 0.2");
  }
  for (const auto* d : {&view_distortion, &light_distortion}) {
    RELIT_REQUIRE(d->size() == 5, "distortion must be 5 numbers (k1, k2, p1, p2, k3), got ",
                  d->size());
    RELIT_REQUIRE(std::abs((*d)[0]) < 0.5 && std::abs((*d)[1]) < 0.5 && std::abs((*d)[2]) < 0.05 &&
                      std::abs((*d)[3]) < 0.05 && std::abs((*d)[4]) < 0.5,
                  "distortion coefficients are outside the range of phone lenses "
                  "(|k1|,|k2|,|k3| < 0.5, |p1|,|p2| < 0.05)");
  }
  RELIT_REQUIRE(distance_min_m >= 0.1 && distance_min_m <= distance_max_m && distance_max_m <= 5,
                "camera distances must satisfy 0.1 <= distance_min_m <= distance_max_m <= 5, got [",
                distance_min_m, ", ", distance_max_m, "]");
  RELIT_REQUIRE(elevation_min_deg >= 5 && elevation_min_deg <= elevation_max_deg &&
                    elevation_max_deg <= 85,
                "elevations must satisfy 5 <= elevation_min_deg <= elevation_max_deg <= 85 "
                "(upper hemisphere, above the table), got [",
                elevation_min_deg, ", ", elevation_max_deg, "]");
  RELIT_REQUIRE(roll_max_deg >= 0 && roll_max_deg <= 45, "roll_max_deg must be in [0, 45], got ",
                roll_max_deg);
  RELIT_REQUIRE(jitter_m >= 0 && jitter_m <= 0.02, "jitter_m must be in [0, 0.02], got ", jitter_m);
  RELIT_REQUIRE(jitter_deg >= 0 && jitter_deg <= 3, "jitter_deg must be in [0, 3], got ", jitter_deg);
  RELIT_REQUIRE(aim_error_m >= 0 && aim_error_m <= 0.1, "aim_error_m must be in [0, 0.1], got ",
                aim_error_m);
  RELIT_REQUIRE(flash_offset_cam_m.size() == 3, "flash_offset_cam_m must be 3 numbers (x, y, z), got ",
                flash_offset_cam_m.size());
  RELIT_REQUIRE(std::hypot(flash_offset_cam_m[0], flash_offset_cam_m[1], flash_offset_cam_m[2]) <= 0.1,
                "flash_offset_cam_m must be within 0.1 m of the lens");
  RELIT_REQUIRE(exposure > 0 && full_well_e >= 10 && read_noise_e >= 0,
                "sensor: exposure must be > 0, full_well_e >= 10, read_noise_e >= 0");
  RELIT_REQUIRE(audio_offset_min_s >= 0 && audio_offset_min_s <= audio_offset_max_s,
                "audio offsets must satisfy 0 <= audio_offset_min_s <= audio_offset_max_s, got [",
                audio_offset_min_s, ", ", audio_offset_max_s, "]");
  // The two recordings must overlap long enough to hear shared claps.
  RELIT_REQUIRE(audio_offset_max_s <= duration_s() - 0.5,
                "audio_offset_max_s = ", audio_offset_max_s, " s leaves less than 0.5 s of overlap "
                "between the ", duration_s(), " s recordings: lower it or raise frames_per_video");
  RELIT_REQUIRE(clap_count >= 1, "clap_count must be >= 1");
  RELIT_REQUIRE(envmap_width_px % 2 == 0, "envmap_width_px must be even, got ", envmap_width_px);
  board.Check();
}

nlohmann::json SynthOptions::ToJson() const {
  return {
      {"preset", preset}, {"mesh_path", mesh_path}, {"mesh_height_m", mesh_height_m},
      {"mesh_y_up", mesh_y_up}, {"size", size}, {"seed", seed}, {"out", out},
      {"assets_dir", assets_dir}, {"geometry_pass", geometry_pass}, {"truth_only", truth_only},
      {"eval_only", eval_only}, {"board_clip_frames", board_clip_frames},
      {"width_px", width_px}, {"height_px", height_px}, {"fps", fps},
      {"frames_per_video", frames_per_video}, {"samples_per_pixel", samples_per_pixel},
      {"max_depth", max_depth}, {"crf", crf}, {"display_rotation_deg", display_rotation_deg},
      {"light_frames_per_video", light_frames_per_video}, {"light_fps", light_fps},
      {"view_audio_rate_hz", view_audio_rate_hz}, {"light_audio_rate_hz", light_audio_rate_hz},
      {"light_width_px", light_width_px}, {"light_height_px", light_height_px},
      {"light_display_rotation_deg", light_display_rotation_deg},
      {"view_audio_start_s", view_audio_start_s}, {"light_audio_start_s", light_audio_start_s},
      {"view_rolling_shutter_s", view_rolling_shutter_s},
      {"light_rolling_shutter_s", light_rolling_shutter_s},
      {"view_exposure_drift", view_exposure_drift}, {"light_exposure_drift", light_exposure_drift},
      {"view_flash_shadow_factor", view_flash_shadow_factor},
      {"view_flash_shadow_edge_m", view_flash_shadow_edge_m},
      {"view_hfov_deg", view_hfov_deg}, {"light_hfov_deg", light_hfov_deg},
      {"view_principal_offset", view_principal_offset},
      {"light_principal_offset", light_principal_offset},
      {"view_distortion", view_distortion}, {"light_distortion", light_distortion},
      {"distance_min_m", distance_min_m}, {"distance_max_m", distance_max_m},
      {"elevation_min_deg", elevation_min_deg}, {"elevation_max_deg", elevation_max_deg},
      {"view_turns", view_turns}, {"light_speed_ratio", light_speed_ratio},
      {"roll_max_deg", roll_max_deg}, {"jitter_m", jitter_m}, {"jitter_deg", jitter_deg},
      {"aim_error_m", aim_error_m}, {"flash_offset_cam_m", flash_offset_cam_m},
      {"flash_intensity_w_per_sr", flash_intensity_w_per_sr},
      {"geometry_ambient_scale", geometry_ambient_scale}, {"exposure", exposure},
      {"full_well_e", full_well_e}, {"read_noise_e", read_noise_e},
      {"audio_offset_min_s", audio_offset_min_s}, {"audio_offset_max_s", audio_offset_max_s},
      {"clap_count", clap_count}, {"eval_views", eval_views},
      {"eval_interpolation_views", eval_interpolation_views},
      {"eval_samples_per_pixel", eval_samples_per_pixel},
      {"eval_noise_twin", eval_noise_twin},
      {"eval_point_lights", eval_point_lights},
      {"eval_directional_lights", eval_directional_lights},
      {"envmap_width_px", envmap_width_px}, {"eval_min_angle_deg", eval_min_angle_deg},
      {"board", relit::ToJson(board)},
  };
}

}  // namespace relit::synth
