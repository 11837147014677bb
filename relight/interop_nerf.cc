// NeRF-style transforms.json with per-frame point-light positions (interop.h).
#include <cmath>
#include <filesystem>

#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/workspace.h"
#include "relight/interop.h"
#include "relight/plan.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

Eigen::Matrix4d NerfTransformMatrix(const Rigid3& cam_from_world) {
  // OpenCV camera axes (x right, y down, z forward) -> OpenGL (x right, y up,
  // z backwards): flip the camera's y and z columns of world_from_cam.
  Eigen::Matrix4d world_from_cam = cam_from_world.Inverse().ToMatrix();
  world_from_cam.col(1) *= -1;
  world_from_cam.col(2) *= -1;
  world_from_cam.row(3) << 0, 0, 0, 1;  // not -0
  return world_from_cam;
}

bool ProjectWithNerfCamera(const Eigen::Matrix4d& transform_matrix, double fl_x, double fl_y, double cx, double cy,
                           const Eigen::Vector3d& point_world, Eigen::Vector2d* pixel) {
  // The NeRF ray through pixel corner coordinates (x, y) is
  // ((x - cx) / fl_x, -(y - cy) / fl_y, -1) in the OpenGL camera frame.
  const Eigen::Vector4d p = transform_matrix.inverse() * point_world.homogeneous();
  if (p.z() >= 0) return false;
  const double depth = -p.z();
  const Eigen::Vector2d corner(cx + fl_x * p.x() / depth, cy - fl_y * p.y() / depth);
  *pixel = corner - Eigen::Vector2d(0.5, 0.5);  // corner convention -> relit's pixel centres
  return true;
}

namespace {

json Matrix4ToJson(const Eigen::Matrix4d& m) {
  json rows = json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return rows;
}

// The camera fields shared by the file and every frame (nerfstudio names;
// cx, cy with the top-left pixel corner at (0, 0)).
json CameraFields(const Intrinsics& in) {
  return {{"fl_x", in.fx}, {"fl_y", in.fy}, {"cx", in.cx + 0.5}, {"cy", in.cy + 0.5},
          {"w", in.width}, {"h", in.height}};
}

}  // namespace

json ExportNerf(const std::string& workspace, const std::string& out_dir, const InteropOptions& options) {
  const fs::path root = fs::absolute(workspace);
  const CamerasFile cameras = ReadCalibCameras(root.string());
  const fs::path lights_path = root / "calib" / "lights.json";
  RELIT_REQUIRE(fs::exists(lights_path), lights_path.string(), " is missing: run relit-calib first");
  const LightsFile lights = ReadLightsFile(lights_path.string());
  const fs::path proxy_path = root / "reconstruct" / "proxy.json";
  RELIT_REQUIRE(fs::exists(proxy_path), proxy_path.string(), " is missing: run relit-reconstruct first");
  const ProxyFile proxy = ReadProxyFile(proxy_path.string());
  const fs::path plan_path = root / "relight" / "plan" / "plan.json";
  const bool has_plan = fs::exists(plan_path);
  const Plan plan = has_plan ? ReadPlan(plan_path.string()) : Plan();

  const Intrinsics& in = cameras.undistorted_view;
  json header = CameraFields(in);
  header["camera_model"] = "OPENCV";  // nerfstudio; zero distortion: the frames are undistorted
  for (const char* k : {"k1", "k2", "p1", "p2"}) header[k] = 0.0;
  header["camera_angle_x"] = 2 * std::atan(0.5 * in.width / in.fx);
  header["camera_angle_y"] = 2 * std::atan(0.5 * in.height / in.fy);
  header["camera_intrinsics"] = {in.cx + 0.5, in.cy + 0.5, in.fx, in.fy};  // NRHints: [cx, cy, fx, fy]
  header["relit"] = {
      {"units", "metres"},
      {"world", "board frame: origin and x axis from the ChArUco board, +Z up (docs/conventions.md)"},
      {"transform_matrix", "camera-to-world, OpenGL camera axes (x right, y up, z backwards)"},
      {"pl_pos", "flash (point light) position in world metres, from calib/lights.json"},
      {"images", "undistorted linear half-float EXR, BT.709 primaries, relative linear radiance"},
      {"masks", "8-bit PNG mattes of the object (255 = object)"},
      {"object_centre_m", ToJson(proxy.object_centre_m)},
      {"object_radius_m", proxy.object_radius_m}};

  AtomicDir out(out_dir);
  fs::create_directories(out.path() / "images");
  fs::create_directories(out.path() / "masks");
  json all = json::array(), train = json::array(), validation = json::array();
  int linked = 0, without_light = 0, without_matte = 0, unreliable = 0;
  for (const CalibratedFrame* frame : cameras.FramesOf("view")) {
    if (frame->image_linear.empty()) continue;
    const FrameLight* light = lights.Find(frame->name);
    if (light == nullptr) {
      ++without_light;
      continue;
    }
    const fs::path source = root / frame->image_linear;
    RELIT_REQUIRE(fs::exists(source), "NeRF export: ", source.string(), " (frame ", frame->name,
                  ") is missing: rerun relit-calib");
    const std::string stem = fs::path(frame->image_linear).stem().string();
    const std::string image = "images/" + stem + ".exr";
    linked += LinkOrCopyFile(source.string(), (out.path() / image).string(), options.link_images);
    json entry = CameraFields(in);
    entry["file_path"] = image;
    entry["file_ext"] = "";  // NRHints appends file_ext to file_path; the path has it already
    entry["transform_matrix"] = Matrix4ToJson(NerfTransformMatrix(frame->cam_from_world));
    entry["pl_pos"] = ToJson(light->position_m);
    entry["pl_reliable"] = light->reliable;
    entry["name"] = frame->name;
    entry["time_s"] = frame->time_s;
    unreliable += light->reliable ? 0 : 1;
    if (const ViewMatte* matte = proxy.Find(frame->name)) {
      const fs::path matte_path = root / matte->matte;
      RELIT_REQUIRE(fs::exists(matte_path), "NeRF export: matte ", matte_path.string(),
                    " is missing: rerun relit-reconstruct");
      const Image alpha = ReadImage(matte_path.string()).SelectChannels(std::vector<int>{0});
      entry["mask_path"] = "masks/" + stem + ".png";
      WriteImage((out.path() / "masks" / (stem + ".png")).string(), alpha, PixelStorage::kUint8);
    } else {
      ++without_matte;
    }
    all.push_back(entry);
    if (has_plan) {
      const int index = plan.FrameIndex(frame->name);
      if (index >= 0) (plan.frames[index].validation ? validation : train).push_back(entry);
    }
  }
  RELIT_REQUIRE(!all.empty(), "NeRF export: no phone V frame has both an undistorted image and a flash position (",
                (root / "calib").string(), ")");
  if (without_light > 0) spdlog::warn("NeRF export: {} frames without a flash position left out", without_light);
  if (without_matte > 0) spdlog::warn("NeRF export: {} frames without a matte (no mask_path)", without_matte);
  auto write = [&](const std::string& name, const json& frames) {
    json file = header;
    file["frames"] = frames;
    AtomicWriteFile(out.path() / name, file.dump(2) + "\n");
  };
  write("transforms.json", all);
  if (has_plan) {
    // Splits as the relight plan made them (NRHints reads train/val/test).
    write("transforms_train.json", train);
    write("transforms_val.json", validation);
    write("transforms_test.json", validation);
  }
  out.Commit();
  spdlog::info("interop: transforms.json with {} frames -> {}", all.size(), out.target().string());
  return {{"folder", out.target().filename().string()},
          {"frames", all.size()},
          {"train_frames", train.size()},
          {"validation_frames", validation.size()},
          {"splits_from_plan", has_plan},
          {"frames_without_light", without_light},
          {"frames_without_matte", without_matte},
          {"unreliable_lights", unreliable},
          {"images_hard_linked", linked}};
}

}  // namespace relit::relight
