// COLMAP text model of the calibrated phone V cameras (interop.h).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>
#include <tuple>

#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/color.h"
#include "core/error.h"
#include "core/image.h"
#include "core/workspace.h"
#include "relight/interop.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

void WriteColmapPinholeModel(const std::string& dir, const Intrinsics& pinhole, const std::vector<ColmapImage>& images,
                             const std::vector<Eigen::Vector3d>& points,
                             const std::vector<Eigen::Vector3i>& colors) {
  RELIT_CHECK(colors.empty() || colors.size() == points.size());
  RELIT_REQUIRE(pinhole.distortion.IsZero(), "COLMAP export: the camera must be the undistorted pinhole camera");
  fs::create_directories(dir);
  std::ostringstream cameras;
  cameras.precision(17);
  // COLMAP's pixel convention puts the top-left pixel's centre at (0.5, 0.5).
  cameras << "# relit: the undistorted phone V camera, COLMAP pixel convention (0.5, 0.5)\n"
             "# CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
          << "1 PINHOLE " << pinhole.width << " " << pinhole.height << " " << pinhole.fx << " " << pinhole.fy << " "
          << pinhole.cx + 0.5 << " " << pinhole.cy + 0.5 << "\n";
  AtomicWriteFile(fs::path(dir) / "cameras.txt", cameras.str());

  std::ostringstream out;
  out.precision(17);
  out << "# relit: cam_from_world in the world (board) frame, metres, +Z up\n"
         "# IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
         "# POINTS2D[] as (X, Y, POINT3D_ID): empty (poses from calibration, not from features)\n";
  for (size_t i = 0; i < images.size(); ++i) {
    const Eigen::Quaterniond& q = images[i].cam_from_world.rotation;
    const Eigen::Vector3d& t = images[i].cam_from_world.translation;
    out << i + 1 << " " << q.w() << " " << q.x() << " " << q.y() << " " << q.z() << " " << t.x() << " " << t.y()
        << " " << t.z() << " 1 " << images[i].name << "\n\n";
  }
  AtomicWriteFile(fs::path(dir) / "images.txt", out.str());

  std::ostringstream pts;
  pts.precision(9);
  pts << "# relit: the proxy mesh's vertices (world frame, metres), no tracks\n"
         "# POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n";
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3i c = colors.empty() ? Eigen::Vector3i(128, 128, 128) : colors[i];
    pts << i + 1 << " " << points[i].x() << " " << points[i].y() << " " << points[i].z() << " " << c.x() << " "
        << c.y() << " " << c.z() << " 0\n";
  }
  AtomicWriteFile(fs::path(dir) / "points3D.txt", pts.str());
}

namespace {

// One point per distinct vertex position (OBJ loading splits vertices at UV
// seams), with the uv of its first occurrence.
void WeldVertices(const render::TriangleMesh& mesh, std::vector<Eigen::Vector3d>* points,
                  std::vector<Eigen::Vector2f>* uvs) {
  std::map<std::tuple<float, float, float>, size_t> seen;
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Eigen::Vector3f& p = mesh.positions[i];
    if (!seen.emplace(std::make_tuple(p.x(), p.y(), p.z()), points->size()).second) continue;
    points->push_back(p.cast<double>());
    uvs->push_back(mesh.has_uvs() ? mesh.uvs[i] : Eigen::Vector2f::Zero());
  }
}

}  // namespace

json ExportColmap(const std::string& workspace, const std::string& out_dir, const InteropOptions& options,
                  const BakedTexture* bake) {
  const fs::path root = fs::absolute(workspace);
  const CamerasFile cameras = ReadCalibCameras(root.string());
  AtomicDir out(out_dir);
  fs::create_directories(out.path() / "images");
  std::vector<ColmapImage> images;
  int linked = 0;
  int converted = 0;
  for (const CalibratedFrame* frame : cameras.FramesOf("view")) {
    if (frame->image_8bit.empty() && frame->image_linear.empty()) continue;  // not undistorted
    const std::string name = fs::path(frame->image_8bit.empty() ? frame->image_linear : frame->image_8bit)
                                 .stem().string() + ".png";
    const fs::path target = out.path() / "images" / name;
    if (!frame->image_8bit.empty()) {
      const fs::path source = root / frame->image_8bit;
      RELIT_REQUIRE(fs::exists(source), "COLMAP export: ", source.string(), " (frame ", frame->name,
                    ") is missing: rerun relit-calib");
      linked += LinkOrCopyFile(source.string(), target.string(), options.link_images);
    } else {
      // No 8-bit copy: encode the linear frame as calib would (sRGB, clipped).
      const fs::path source = root / frame->image_linear;
      RELIT_REQUIRE(fs::exists(source), "COLMAP export: ", source.string(), " (frame ", frame->name,
                    ") is missing: rerun relit-calib");
      Image image = ReadImage(source.string()).SelectChannels(std::vector<int>{0, 1, 2});
      for (float& value : image.data()) value = LinearToSrgb(std::clamp(value, 0.f, 1.f));
      WriteImage(target.string(), image, PixelStorage::kUint8);
      ++converted;
    }
    images.push_back({name, frame->cam_from_world});
  }
  RELIT_REQUIRE(!images.empty(), "COLMAP export: ", (root / "calib" / "cameras.json").string(),
                " lists no undistorted phone V frame");

  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2f> uvs;
  const fs::path proxy_path = root / "reconstruct" / "proxy.json";
  RELIT_REQUIRE(fs::exists(proxy_path), proxy_path.string(), " is missing: run relit-reconstruct first");
  WeldVertices(render::LoadMesh((root / ReadProxyFile(proxy_path.string()).mesh).string()), &points, &uvs);
  std::vector<Eigen::Vector3i> colors;
  if (bake != nullptr) {
    for (const Eigen::Vector2f& uv : uvs) {
      const Eigen::Vector3f c = SampleTexture(bake->linear, uv) * static_cast<float>(options.bake_exposure);
      Eigen::Vector3i rgb;
      for (int k = 0; k < 3; ++k) {
        rgb[k] = static_cast<int>(std::lround(255 * LinearToSrgb(std::clamp(c[k], 0.f, 1.f))));
      }
      colors.push_back(rgb);
    }
  }
  WriteColmapPinholeModel((out.path() / "sparse" / "0").string(), cameras.undistorted_view, images, points, colors);
  out.Commit();
  spdlog::info("interop: COLMAP model of {} cameras and {} proxy vertices -> {}", images.size(), points.size(),
               out.target().string());
  return {{"folder", out.target().filename().string()},
          {"model", "sparse/0"},
          {"camera_model", "PINHOLE"},
          {"images", images.size()},
          {"images_hard_linked", linked},
          {"images_encoded_from_linear", converted},
          {"points", points.size()},
          {"points_colored_by_bake", bake != nullptr}};
}

}  // namespace relit::relight
