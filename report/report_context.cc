#include "report/report_context.h"

#include <cmath>
#include <fstream>

#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/camera.h"
#include "core/color.h"
#include "core/error.h"
#include "core/image.h"
#include "core/render/path_tracer.h"
#include "core/render/scene.h"

namespace relit::report {

namespace fs = std::filesystem;

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string Lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

}  // namespace

ReportContext::ReportContext(fs::path workspace, fs::path out, const ReportOptions& options)
    : workspace_(std::move(workspace)), out_(std::move(out)), options_(options) {
  fs::create_directories(out_ / "assets");
}

bool ReportContext::Has(const std::string& relative) const { return fs::exists(workspace_ / relative); }

std::string ReportContext::WriteAsset(const std::string& name, const std::string& content) {
  AtomicWriteFile(out_ / "assets" / name, content);
  return "assets/" + name;
}

std::string ReportContext::Thumbnail(const fs::path& source, const std::string& name, int width_px) {
  if (width_px <= 0) width_px = options_.thumbnail_width_px;
  RELIT_REQUIRE(fs::exists(source), "image ", source.string(), " is missing (listed by the stage's JSON file)");
  Image image = ReadImage(source.string());
  RELIT_REQUIRE(!image.empty(), "image ", source.string(), " is empty");
  // Colour channels only; an alpha channel would show the page background.
  if (image.channels() >= 3) {
    image = image.SelectChannels(std::vector<int>{0, 1, 2});
  } else if (image.channels() == 2) {
    image = image.SelectChannels(std::vector<int>{0});
  }
  // EXRs are linear; PNG/JPEG are already encoded (colour sRGB, mattes linear).
  if (Lower(source.extension().string()) == ".exr") image = EncodeImage(image, TransferFunction::kSrgb);
  cv::Mat mat = image.ToMat();
  if (mat.cols != width_px) {
    const int height = std::max(1, static_cast<int>(std::lround(double(mat.rows) * width_px / mat.cols)));
    cv::Mat scaled;
    cv::resize(mat, scaled, cv::Size(width_px, height), 0, 0, width_px < mat.cols ? cv::INTER_AREA : cv::INTER_LINEAR);
    mat = scaled;
  }
  const std::string file = name + ".png";
  WriteImage((out_ / "assets" / file).string(), Image::FromMat(mat), PixelStorage::kUint8);
  return "assets/" + file;
}

std::vector<std::string> ReportContext::MeshPreviews(const fs::path& mesh_path, const Eigen::Vector3d& centre_m,
                                                     double radius_m, const std::string& name) {
  const MeshPreviewOptions& o = options_.mesh_preview;
  std::vector<std::string> srcs;
  if (o.views == 0) return srcs;
  render::TriangleMesh mesh = render::LoadMesh(mesh_path.string());
  RELIT_REQUIRE(!mesh.triangles.empty(), "mesh ", mesh_path.string(), " has no triangles");
  if (!mesh.has_normals()) mesh.ComputeVertexNormals();
  if (radius_m <= 0) {
    const Eigen::AlignedBox3f box = mesh.Bounds();
    radius_m = 0.5 * (box.max() - box.min()).norm();
  }
  const double fov = 35.0 * kPi / 180;
  const double distance = 1.15 * radius_m / std::sin(fov / 2);
  const float albedo = 0.7f;
  // A headlight at the camera: radiance of a facing surface albedo/pi * I/d^2 ~ 0.8.
  const float intensity = static_cast<float>(0.8 * kPi / albedo * distance * distance);
  render::RenderOptions render_options;
  render_options.samples_per_pixel = o.samples_per_pixel;
  render_options.max_depth = 1;  // direct light: enough to read the shape
  render_options.seed = 1;
  const Intrinsics intrinsics = Intrinsics::FromFov(o.size_px, o.size_px, fov);
  for (int k = 0; k < o.views; ++k) {
    const double azimuth = 2 * kPi * k / o.views - kPi / 2;  // first view from -Y: the board's "front"
    const double elevation = o.elevation_deg * kPi / 180;
    const Eigen::Vector3d eye =
        centre_m + distance * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                              std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    render::Scene scene;
    scene.AddObject(mesh, render::Material::Lambert(render::Rgb::Constant(albedo)), 0);
    scene.AddLight(render::PointLight{eye.cast<float>(), render::Rgb::Constant(intensity)});
    scene.Commit();
    const Camera camera(intrinsics, LookAt(eye, centre_m, Eigen::Vector3d::UnitZ()));
    const render::RenderResult result = render::RenderImage(scene, camera, render_options);
    Image composite(o.size_px, o.size_px, 3);
    const float background = 0.85f;  // linear; light grey once encoded
    for (int y = 0; y < o.size_px; ++y) {
      for (int x = 0; x < o.size_px; ++x) {
        const float a = result.alpha.at(x, y, 0);
        for (int c = 0; c < 3; ++c) {
          composite.at(x, y, c) = result.radiance.at(x, y, c) + (1 - a) * background;
        }
      }
    }
    const std::string file = name + "_" + std::to_string(k) + ".png";
    WriteImage((out_ / "assets" / file).string(), EncodeImage(composite, TransferFunction::kSrgb),
               PixelStorage::kUint8);
    srcs.push_back("assets/" + file);
  }
  return srcs;
}

void ReportContext::AddWarning(const std::string& section, const std::string& text) {
  spdlog::warn("{}: {}", section, text);
  warnings_.push_back(section + ": " + text);
}

nlohmann::json ReadAnyJson(const fs::path& path) {
  std::ifstream in(path);
  RELIT_REQUIRE(in.good(), "cannot open ", path.string());
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    Fail(path.string(), ": invalid JSON: ", e.what());
  }
}

std::vector<size_t> EvenlySpread(size_t total, size_t count) {
  std::vector<size_t> picks;
  if (total == 0 || count == 0) return picks;
  if (total <= count) {
    for (size_t i = 0; i < total; ++i) picks.push_back(i);
    return picks;
  }
  for (size_t k = 0; k < count; ++k) {
    picks.push_back(count == 1 ? total / 2 : k * (total - 1) / (count - 1));
  }
  return picks;
}

}  // namespace relit::report
