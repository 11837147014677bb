#include "relight/support_plane.h"

#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/workspace.h"
#include "core/render/mesh.h"

namespace relit::relight {

void SupportPlane::Check(const std::string& where) const {
  if (!enabled) return;
  board.Check();
  auto albedo_ok = [](double a) { return std::isfinite(a) && a >= 0 && a <= 1; };
  RELIT_REQUIRE(albedo_ok(paper_albedo) && albedo_ok(ink_albedo) && ink_albedo <= paper_albedo, where,
                ": support plane paper_albedo and ink_albedo must be in [0, 1] with ink <= paper, got ",
                paper_albedo, " and ", ink_albedo);
  RELIT_REQUIRE(albedo_ok(table_albedo.x()) && albedo_ok(table_albedo.y()) && albedo_ok(table_albedo.z()), where,
                ": support plane table_albedo must be 3 values in [0, 1]");
  RELIT_REQUIRE(std::isfinite(paper_margin_m) && paper_margin_m >= 0 && paper_margin_m < 1, where,
                ": support plane paper_margin_m must be in [0, 1) m, got ", paper_margin_m);
  RELIT_REQUIRE(std::isfinite(table_half_size_m) && table_half_size_m > 0.5 * std::max(board.width_m(), board.height_m()),
                where, ": support plane table_half_size_m must cover the board, got ", table_half_size_m);
  RELIT_REQUIRE(albedo_map.empty() || std::filesystem::exists(albedo_map), where, ": support plane albedo map ",
                albedo_map, " is missing: run `relit-relight cues` again");
}

nlohmann::json SupportPlane::ToJson() const {
  if (!enabled) return {{"enabled", false}};
  return {{"enabled", true},
          {"board", relit::ToJson(board)},
          {"paper_albedo", paper_albedo},
          {"ink_albedo", ink_albedo},
          {"paper_margin_m", paper_margin_m},
          {"table_albedo", relit::ToJson(table_albedo)},
          {"table_half_size_m", table_half_size_m},
          {"albedo_map", albedo_map.empty() ? "" : std::filesystem::path(albedo_map).filename().string()}};
}

SupportPlane SupportPlane::FromJson(const nlohmann::json& j, const std::string& where, const std::string& dir) {
  SupportPlane plane;
  if (j.is_null() || !j.value("enabled", false)) return plane;
  const std::string at = where + ": support_plane";
  plane.enabled = true;
  plane.board = BoardSpecFromJson(JsonField(j, "board", at), at + ".board");
  plane.paper_albedo = JsonNumber(j, "paper_albedo", at);
  plane.ink_albedo = JsonNumber(j, "ink_albedo", at);
  plane.paper_margin_m = JsonNumber(j, "paper_margin_m", at);
  plane.table_albedo = Vector3FromJson(JsonField(j, "table_albedo", at), at + ".table_albedo");
  plane.table_half_size_m = JsonNumber(j, "table_half_size_m", at);
  const std::string map = j.value("albedo_map", std::string());  // absent before the maps existed
  if (!map.empty()) plane.albedo_map = (std::filesystem::path(dir) / map).string();
  plane.Check(where);
  return plane;
}

BoardQuad MakeBoardQuad(const SupportPlane& plane) {
  // ~2 texels per mm, whole texels per square so the squares stay exact.
  const double square_px = std::max(8.0, std::round(plane.board.square_length_m * 2000));
  const double pixels_per_metre = square_px / plane.board.square_length_m;
  const int margin_px = static_cast<int>(std::lround(plane.paper_margin_m * pixels_per_metre));
  const cv::Mat print = DrawBoardImage(plane.board, pixels_per_metre, margin_px);
  BoardQuad quad;
  quad.print_albedo = Image(print.cols, print.rows, 3);
  for (int y = 0; y < print.rows; ++y) {
    for (int x = 0; x < print.cols; ++x) {
      const double ink = 1.0 - print.at<uint8_t>(y, x) / 255.0;
      const float a = static_cast<float>(plane.paper_albedo + (plane.ink_albedo - plane.paper_albedo) * ink);
      for (int c = 0; c < 3; ++c) quad.print_albedo.at(x, y, c) = a;
    }
  }
  quad.half_x_m = 0.5 * print.cols / pixels_per_metre;
  quad.half_y_m = 0.5 * print.rows / pixels_per_metre;
  return quad;
}

void AddSupportPlane(const SupportPlane& plane, render::Scene* scene) {
  if (!plane.enabled) return;
  BoardQuad quad = MakeBoardQuad(plane);
  // As the synthetic board: u along the image width, v up, centred on the
  // world origin, so the printed top-left corner lands where WorldFromBoard says.
  render::Material paper = render::Material::Lambert(render::Rgb::Zero());
  paper.diffuse_albedo = plane.albedo_map.empty() ? render::Texture::FromImage(quad.print_albedo, false)
                                                  : render::Texture::FromFile(plane.albedo_map, false);
  scene->AddObject(render::MakeQuad(Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(),
                                    static_cast<float>(quad.half_x_m), static_cast<float>(quad.half_y_m)),
                   std::move(paper), kSupportBoardObjectId);
  const float half = static_cast<float>(plane.table_half_size_m);
  scene->AddObject(render::MakeQuad(Eigen::Vector3f(0, 0, -0.0005f), Eigen::Vector3f::UnitX(),
                                    Eigen::Vector3f::UnitY(), half, half),
                   render::Material::Lambert(plane.table_albedo.cast<float>()), kSupportTableObjectId);
}

}  // namespace relit::relight
