#include "reconstruct/test_workspace.h"

#include <cmath>
#include <filesystem>
#include <string>
#include <system_error>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/color.h"
#include "core/image.h"
#include "core/render/envmaps.h"
#include "core/render/path_tracer.h"
#include "core/render/scene.h"
#include "reconstruct/mesh_cleanup.h"
#include "tools/synth/capture_plan.h"
#include "tools/synth/scene.h"
#include "tools/synth/synth_options.h"

namespace relit::reconstruct::testing {

namespace fs = std::filesystem;

TestWorkspace MakeTestWorkspace(const std::string& dir, int frames, int samples_per_pixel, double rough_offset_m,
                                int geometry_frames) {
  TestWorkspace ws;
  ws.dir = dir;
  fs::remove_all(dir);
  fs::create_directories(fs::path(dir) / "calib" / "undistorted");
  synth::SynthOptions options = synth::SynthOptions::ForSize("tiny");
  options.out = dir;  // required by the plan's option check; nothing is written there by synth
  options.geometry_pass = geometry_frames > 0;
  const synth::SynthScene scene = synth::BuildScene("spot", options.board, synth::DefaultAssetsDir());
  const synth::CapturePlan plan = synth::MakeCapturePlan(options, scene);
  render::TriangleMesh scan;
  for (const synth::SynthObject& object : scene.objects) {
    render::TriangleMesh* target = object.foreground ? &ws.truth_mesh : &scan;
    for (render::TriangleMesh* m : {target, object.foreground ? &scan : nullptr}) {
      if (!m) continue;
      const int base = static_cast<int>(m->positions.size());
      m->positions.insert(m->positions.end(), object.mesh.positions.begin(), object.mesh.positions.end());
      for (const Eigen::Vector3i& t : object.mesh.triangles) m->triangles.push_back(t + Eigen::Vector3i::Constant(base));
    }
  }
  ws.user_mesh = (fs::path(dir) / "user_mesh.obj").string();
  render::SaveMesh(ws.user_mesh, scan);
  // Equal positions (OBJ seams) merged so the surface is offset without cracks.
  render::TriangleMesh rough = WeldEqualPositions(ws.truth_mesh);
  rough.ComputeVertexNormals();
  for (size_t i = 0; i < rough.positions.size(); ++i) {
    rough.positions[i] += static_cast<float>(rough_offset_m) * rough.normals[i];
  }
  rough.normals.clear();
  for (const synth::SynthObject& object : scene.objects) {
    if (object.foreground) continue;
    const int base = static_cast<int>(rough.positions.size());
    rough.positions.insert(rough.positions.end(), object.mesh.positions.begin(), object.mesh.positions.end());
    for (const Eigen::Vector3i& t : object.mesh.triangles) rough.triangles.push_back(t + Eigen::Vector3i::Constant(base));
  }
  ws.rough_mesh = (fs::path(dir) / "rough_mesh.obj").string();
  render::SaveMesh(ws.rough_mesh, rough);

  ws.cameras.board = options.board;
  ws.cameras.devices["view"] = plan.view_intrinsics;
  ws.cameras.undistorted_view = plan.view_intrinsics.WithoutDistortion();
  render::Scene render_scene;
  scene.AddTo(&render_scene);
  render_scene.Commit();
  const render::EnvironmentLight room(render::MakeSoftRoomMap(256), static_cast<float>(options.geometry_ambient_scale));
  for (const synth::VideoPlan* video : {&plan.view, &plan.geometry}) {
    const bool geometry = video == &plan.geometry;
    const int wanted = geometry ? geometry_frames : frames;
    if (wanted <= 0) continue;
    if (geometry) ws.cameras.devices["geometry"] = plan.view_intrinsics;
    const int count = static_cast<int>(video->frames.size());
    for (int i = 0; i < wanted; ++i) {
      const synth::FramePlan& f = video->frames[static_cast<size_t>(i) * count / wanted];
      render_scene.ClearLights();
      if (geometry) {
        render_scene.SetEnvironment(room);
      } else {
        render_scene.AddLight(render::PointLight{f.light_position_world.cast<float>(),
                                                 render::Rgb::Constant(static_cast<float>(options.flash_intensity_w_per_sr))});
      }
      CalibratedFrame frame;
      char name[32];
      std::snprintf(name, sizeof(name), "%s/%06d", geometry ? "geometry" : "view", f.index);
      frame.name = name;
      frame.device = geometry ? "geometry" : "view";
      frame.time_s = f.t_common_s;
      frame.cam_from_world = f.cam_from_world;
      const std::string stem = "calib/undistorted/" + std::string(name);
      frame.image_linear = stem + ".exr";
      frame.image_8bit = stem + ".png";
      const Camera camera = ws.cameras.ViewCamera(frame);
      render::RenderOptions ro;
      ro.samples_per_pixel = samples_per_pixel;
      ro.max_depth = 2;
      ro.seed = static_cast<uint64_t>(f.index + 1 + (geometry ? 100000 : 0));
      ro.alpha_object_ids = scene.ForegroundIds();
      const render::RenderResult result = render::RenderImage(render_scene, camera, ro);
      fs::create_directories((fs::path(dir) / stem).parent_path());
      WriteImage((fs::path(dir) / frame.image_linear).string(), result.radiance);
      WriteImage((fs::path(dir) / frame.image_8bit).string(), EncodeImage(result.radiance, TransferFunction::kSrgb),
                 PixelStorage::kUint8);
      ws.truth_alpha.push_back(result.alpha.ToMat().clone());
      ws.cameras.frames.push_back(frame);
    }
  }
  WriteCamerasFile((fs::path(dir) / "calib" / "cameras.json").string(), ws.cameras);
  return ws;
}

namespace {

struct SharedWorkspace {
  TestWorkspace ws;
  ~SharedWorkspace() {
    std::error_code ignored;
    fs::remove_all(ws.dir, ignored);
  }
};

}  // namespace

const TestWorkspace& SharedTestWorkspace(const std::string& name, int frames, int samples_per_pixel,
                                         double rough_offset_m, int geometry_frames) {
  static const SharedWorkspace shared{MakeTestWorkspace(::testing::TempDir() + "/" + name + "_" +
                                                            std::to_string(getpid()),
                                                        frames, samples_per_pixel, rough_offset_m, geometry_frames)};
  return shared.ws;
}

double RaySphere(const Eigen::Vector3d& origin, const Eigen::Vector3d& ray, const Eigen::Vector3d& centre,
                 double radius) {
  const Eigen::Vector3d oc = origin - centre;
  const double b = oc.dot(ray), disc = b * b - (oc.squaredNorm() - radius * radius);
  return disc < 0 ? -1.0 : -b - std::sqrt(disc);
}

Camera CameraLookingAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, int width, int height,
                       double focal_px) {
  Intrinsics k;
  k.width = width;
  k.height = height;
  k.fx = k.fy = focal_px;
  k.cx = 0.5 * width;
  k.cy = 0.5 * height;
  return Camera(k, LookAt(eye, target, Eigen::Vector3d::UnitZ()));
}

std::vector<Camera> TwoRingsOfCameras(const Eigen::Vector3d& target, double low_deg, double high_deg) {
  std::vector<Camera> cameras;
  for (double elevation_deg : {low_deg, high_deg}) {
    for (int i = 0; i < 12; ++i) {
      const double azimuth = 2 * M_PI * (i + (elevation_deg == high_deg ? 0.5 : 0.0)) / 12;
      const double elevation = elevation_deg * M_PI / 180;
      const Eigen::Vector3d eye = target + 0.4 * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                                                 std::cos(elevation) * std::sin(azimuth),
                                                                 std::sin(elevation));
      cameras.push_back(CameraLookingAt(eye, target, 320, 240, 400));
    }
  }
  return cameras;
}

cv::Mat RenderAnalyticDepth(const Camera& camera,
                            const std::function<double(const Eigen::Vector3d& origin, const Eigen::Vector3d& ray)>& hit,
                            bool table) {
  cv::Mat depth(camera.intrinsics().height, camera.intrinsics().width, CV_32F, cv::Scalar(0));
  const Eigen::Vector3d origin = camera.Center();
  const Eigen::Matrix3d world_from_cam = camera.world_from_cam().rotation.toRotationMatrix();
  for (int y = 0; y < depth.rows; ++y) {
    for (int x = 0; x < depth.cols; ++x) {
      const Eigen::Vector3d ray_cam = camera.PixelToCameraRay(Eigen::Vector2d(x, y));
      const Eigen::Vector3d ray = world_from_cam * ray_cam;
      double t = hit(origin, ray);
      if (t <= 0 && ray.z() < 0 && table) {
        const double t_table = -origin.z() / ray.z();
        const Eigen::Vector3d on_table = origin + t_table * ray;
        if (std::abs(on_table.x()) < 0.15 && std::abs(on_table.y()) < 0.15) t = t_table;
      }
      if (t > 0) depth.at<float>(y, x) = static_cast<float>(t * ray_cam.z());
    }
  }
  return depth;
}

double MatteMse(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::subtract(a, b, d, cv::noArray(), CV_64F);
  return cv::mean(d.mul(d))[0];
}

double MatteSad(const cv::Mat& a, const cv::Mat& b) { return cv::norm(a, b, cv::NORM_L1); }

}  // namespace relit::reconstruct::testing
