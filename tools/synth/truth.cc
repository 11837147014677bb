#include "tools/synth/truth.h"

#include <cstdio>
#include <filesystem>

#include "core/workspace.h"
#include "core/error.h"
#include "core/json_file.h"

namespace relit::synth {

namespace {

std::string FrameNumber(int frame) {
  char buffer[16];
  std::snprintf(buffer, sizeof(buffer), "%06d", frame);
  return buffer;
}

nlohmann::json Vec(const Eigen::Vector3d& v) { return ToJson(v); }

nlohmann::json VideoJson(const VideoPlan& video, const SynthOptions& o, bool with_alpha) {
  nlohmann::json frames = nlohmann::json::array();
  for (const FramePlan& f : video.frames) {
    nlohmann::json frame = {{"index", f.index},
                            {"t_own_s", f.t_own_s},
                            {"t_common_s", f.t_common_s},
                            {"cam_from_world", ToJson(f.cam_from_world)},
                            {"camera_center_world_m", Vec(f.cam_from_world.Inverse().translation)}};
    if (video.lighting == "flash") frame["light_position_world_m"] = Vec(f.light_position_world);
    if (with_alpha) frame["alpha"] = AlphaPath(video.name, f.index);
    if (video.exposure_drift > 0) frame["exposure_scale"] = f.exposure_scale;
    frames.push_back(frame);
  }
  nlohmann::json j = {{"file", video.name + ".mp4"},
                      {"phone", video.phone},
                      {"lighting", video.lighting},
                      {"fps", video.fps},
                      {"audio_sample_rate_hz", video.audio_rate_hz},
                      {"frame_count", static_cast<int>(video.frames.size())},
                      {"start_common_s", video.start_common_s},
                      {"display_rotation_deg", video.display_rotation_deg},
                      {"audio_start_own_s", video.audio_start_s},
                      {"first_frame_pts_s", video.first_frame_pts_s()},
                      {"rolling_shutter_s", video.rolling_shutter_s},
                      {"exposure_drift", video.exposure_drift},
                      {"intrinsics", ToJson(video.intrinsics)},
                      {"frames", frames}};
  if (video.name == "view" && o.view_flash_shadow_factor < 1) {
    j["flash_shadow"] = {{"factor", o.view_flash_shadow_factor},
                         {"edge_m", o.view_flash_shadow_edge_m},
                         {"model", "board and table pixels p with p_xy . unit(-flash_xy) > edge_m: "
                                   "radiance times factor (a mask, not traced)"}};
  }
  if (video.lighting == "environment") {
    j["environment"] = {{"file", kGeometryEnvmapPath}, {"scale", o.geometry_ambient_scale}};
    j["start_common_s"] = nullptr;  // a separate session with its own clock
  }
  return j;
}

}  // namespace

std::string AlphaPath(const std::string& video, int frame) {
  return "truth/" + video + "_alpha/" + FrameNumber(frame) + ".exr";
}
std::string BoardClipFolder(const std::string& phone) { return "board_clip/" + phone; }
std::string BoardClipFramePath(const std::string& phone, int frame) {
  return BoardClipFolder(phone) + "/" + FrameNumber(frame) + ".png";
}
std::string EvalImagePath(const std::string& view, const std::string& light) {
  return "eval/" + view + "/" + light + ".exr";
}
std::string EvalTwinImagePath(const std::string& view, const std::string& light) {
  return "eval/" + view + "/" + light + ".twin.exr";
}

std::string EvalHalfImagePath(const std::string& view, const std::string& light) {
  return "eval/" + view + "/" + light + ".half.exr";
}

std::string EvalAlphaPath(const std::string& view) { return "eval/" + view + "/alpha.exr"; }
std::string EnvmapPath(const std::string& name) { return "eval/envmaps/" + name + ".exr"; }
std::string MeshPath(const std::string& object) { return "truth/meshes/" + object + ".obj"; }
std::string TexturePath(const std::string& texture) { return "truth/textures/" + texture + ".exr"; }

void WriteSceneTruth(const SynthScene& scene, const std::string& out_dir) {
  const std::filesystem::path root(out_dir);
  std::filesystem::create_directories(root / "truth/meshes");
  std::filesystem::create_directories(root / "truth/textures");
  for (const SynthObject& object : scene.objects) {
    render::SaveMesh((root / MeshPath(object.name)).string(), object.mesh);
    for (const auto& [name, image] : object.textures) {
      WriteImage((root / TexturePath(name)).string(), image, PixelStorage::kHalf);
    }
  }
  WriteImage((root / kBoardImagePath).string(), Image::FromMat(scene.board_image),
             PixelStorage::kUint8);
}

nlohmann::json MakeTruthJson(const SynthOptions& o, const SynthScene& scene, const CapturePlan& plan,
                             RenderedParts rendered) {
  nlohmann::json j;
  j["generator"] = "relit-synth";
  j["preset"] = o.preset;
  j["size"] = o.size;
  j["seed"] = o.seed;
  j["rendered"] = rendered.eval;
  j["videos_rendered"] = rendered.videos;
  j["units"] = {{"length", "m"},
                {"time", "s"},
                {"angle", "rad"},
                {"image", "linear RGB radiance (EXR); videos are 8-bit sRGB-encoded"},
                {"point_light_intensity", "W/sr (radiance x m^2)"},
                {"directional_light", "irradiance on a surface facing the light"}};
  j["conventions"] = {
      {"world", "board centre at the origin, +Z up out of the table, x along the printed rows "
                "(core/board.h WorldFromBoard)"},
      {"camera", "OpenCV: x right, y down, z forward; pixel (0,0) is the centre of the top-left "
                 "pixel; cam_from_world maps world points into the camera frame"},
      {"distortion", "OpenCV 5-parameter (k1, k2, p1, p2, k3) on normalised coordinates; video "
                     "frames and mattes are distorted, eval images are undistorted pinhole"},
      {"time", "t_common = t_view = t_light + light_start_offset_s; frame i of a video is at "
               "t_own = i / fps on its phone's clock (videos.<name>.fps; phones may differ); light_start_offset_s > 0 means phone L "
               "started recording after phone V"},
      {"audio", "each audio track starts audio_start_own_s after its video's first frame (own "
                "clock); the shared room sound at common time t is heard at t - start_common_s in "
                "each file"},
      {"container_time", "t_own_s counts from a video's first frame; in the MP4 that frame is at "
                         "first_frame_pts_s (> 0 when the audio starts first), so a reader that "
                         "uses presentation timestamps sees t_own_s + first_frame_pts_s"},
      {"rolling_shutter", "rows are read top to bottom (stored pixels) over rolling_shutter_s; "
                          "t_own_s, t_common_s and cam_from_world are the middle row's"},
      {"display_rotation", "intrinsics and cam_from_world are for the stored pixels; players and "
                           "relit-capture turn the frames clockwise by display_rotation_deg"}};
  j["fps"] = o.fps;
  j["light_start_offset_s"] = plan.light_start_offset_s;
  j["audio"] = {{"sample_rate_hz", o.view_audio_rate_hz},
                {"light_sample_rate_hz", o.light_audio_rate_hz},
                {"clap_times_common_s", plan.clap_times_common_s},
                {"raw_tracks", {{"view", "truth/audio/view.wav"}, {"light", "truth/audio/light.wav"}}}};
  const auto corners = CharucoCornersWorld(scene.board);
  nlohmann::json corner_json = nlohmann::json::array();
  for (const auto& c : corners) corner_json.push_back(Vec(c));
  j["board"] = relit::ToJson(scene.board);
  j["board"].update({{"opencv_layout", "OpenCV 4.6 cv::aruco::CharucoBoard::create"},
                     {"world_from_board", ToJson(WorldFromBoard(scene.board))},
                     {"corners_world_m", corner_json},
                     {"image", kBoardImagePath},
                     {"image_pixels_per_metre", scene.board_pixels_per_metre},
                     {"image_margin_px", scene.board_margin_px},
                     {"albedo_white", 0.80},
                     {"albedo_black", 0.03}});
  j["flash"] = {{"phone", "light"},
                {"offset_cam_m", Vec(plan.flash_offset_cam_m)},
                {"intensity_w_per_sr", {o.flash_intensity_w_per_sr, o.flash_intensity_w_per_sr,
                                        o.flash_intensity_w_per_sr}},
                {"falloff", "inverse square, isotropic point light"},
                {"ambient", "none (dark room)"}};
  j["sensor"] = {{"exposure", o.exposure},
                 {"full_well_e", o.full_well_e},
                 {"read_noise_e", o.read_noise_e},
                 {"model", "value = clamp(exposure * radiance); Poisson(value * full_well_e) + "
                           "N(0, read_noise_e^2) electrons; / full_well_e; clamp; sRGB; 8-bit"},
                 {"exposure_drift", "per frame: exposure times videos.<name>.frames[i].exposure_scale"},
                 {"not_simulated", {"white balance",
                                    "motion blur", "vignetting", "phones visible to each other"}}};
  j["phones"] = {{"view", {{"intrinsics", ToJson(plan.view_intrinsics)}, {"flash", false}}},
                 {"light", {{"intrinsics", ToJson(plan.light_intrinsics)}, {"flash", true}}}};
  j["videos"] = {{"view", VideoJson(plan.view, o, true)}, {"light", VideoJson(plan.light, o, false)}};
  if (!plan.geometry.frames.empty()) j["videos"]["geometry"] = VideoJson(plan.geometry, o, true);
  for (const VideoPlan* clip : {&plan.view_board_clip, &plan.light_board_clip}) {
    if (clip->frames.empty()) continue;
    nlohmann::json poses = nlohmann::json::array();
    for (const FramePlan& f : clip->frames) {
      poses.push_back({{"image", BoardClipFramePath(clip->phone, f.index)},
                       {"cam_from_world", ToJson(f.cam_from_world)}});
    }
    j["board_clips"][clip->phone] = {{"folder", BoardClipFolder(clip->phone)},
                                     {"intrinsics", ToJson(clip->intrinsics)},
                                     {"environment", {{"file", kGeometryEnvmapPath},
                                                      {"scale", o.geometry_ambient_scale}}},
                                     {"frames", poses}};
  }

  nlohmann::json objects = nlohmann::json::array(), background = nlohmann::json::array();
  for (const SynthObject& object : scene.objects) {
    nlohmann::json material = object.material_json;
    for (const char* key : {"diffuse_albedo", "specular_albedo", "roughness"}) {
      if (material[key].is_object()) {
        material[key] = {{"texture", TexturePath(material[key]["texture"].get<std::string>())},
                         {"encoding", "linear, half EXR, OBJ UV convention (v up)"}};
      }
    }
    const Eigen::AlignedBox3f box = object.mesh.Bounds();
    nlohmann::json entry = {{"name", object.name},
                            {"object_id", object.object_id},
                            {"mesh", MeshPath(object.name)},
                            {"has_uvs", object.mesh.has_uvs()},
                            {"triangles", object.mesh.triangles.size()},
                            {"bounds_min_m", Vec(box.min().cast<double>())},
                            {"bounds_max_m", Vec(box.max().cast<double>())},
                            {"material", material}};
    (object.foreground ? objects : background).push_back(entry);
  }
  j["objects"] = objects;
  j["background"] = background;
  j["target_world_m"] = Vec(scene.target_world);
  j["render"] = {{"renderer", "relit path tracer (core/render)"},
                 {"samples_per_pixel", o.samples_per_pixel},
                 {"max_depth", o.max_depth},
                 {"eval_samples_per_pixel", o.eval_samples_per_pixel},
                 {"eval_environment_samples_per_pixel", o.EvalSamplesPerPixel("environment")},
                 {"eval_background_samples_per_pixel", o.eval_background_samples_per_pixel}};

  nlohmann::json lights = nlohmann::json::array();
  for (const EvalLight& light : plan.eval_lights) {
    nlohmann::json l = {{"name", light.name}, {"type", light.type}};
    if (light.type == "point") {
      l["position_world_m"] = Vec(light.position_world);
      l["intensity_w_per_sr"] = Vec(light.rgb);
    } else if (light.type == "directional") {
      l["direction_to_light_world"] = Vec(light.direction_to_light);
      l["irradiance"] = Vec(light.rgb);
    } else {
      l["envmap"] = EnvmapPath(light.envmap);
      l["scale"] = light.rgb.x();
      l["layout"] = "equirectangular, +Z up, row 0 = zenith, u = atan2(y, x) / 2pi";
      if (light.envmap == "sky") {
        l["sun_elevation_rad"] = plan.sun_elevation_rad;
        l["sun_azimuth_rad"] = plan.sun_azimuth_rad;
      }
    }
    lights.push_back(l);
  }
  nlohmann::json views = nlohmann::json::array();
  for (const EvalView& view : plan.eval_views) {
    nlohmann::json images = nlohmann::json::object();
    nlohmann::json halves = nlohmann::json::object();
    for (const EvalLight& light : plan.eval_lights) {
      images[light.name] = EvalImagePath(view.name, light.name);
      halves[light.name] = EvalHalfImagePath(view.name, light.name);
    }
    views.push_back({{"name", view.name},
                     {"cam_from_world", ToJson(view.cam_from_world)},
                     {"camera_center_world_m", Vec(view.cam_from_world.Inverse().translation)},
                     {"min_angle_to_training_views_rad", view.min_angle_to_training_rad},
                     {"set", view.set},
                     {"alpha", EvalAlphaPath(view.name)},
                     {"images", images}});
    if (o.eval_noise_halves) views.back()["images_half"] = halves;
  }
  j["eval"] = {{"intrinsics", ToJson(plan.eval_intrinsics)},
               {"background_visible", true},
               {"lights", lights},
               {"views", views}};
  return j;
}

}  // namespace relit::synth
