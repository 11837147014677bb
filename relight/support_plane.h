// The support plane: the printed board and the table the object stands on.
// After calib it is known geometry (z = 0 in the world frame), and it shapes
// every photo: it bounces the flash onto the object's lower half and receives
// the object's shadow. Cue scenes include it as context geometry with its own
// diffuse material (cue_renderer.h), so the radiance cues hold that bounce
// light instead of leaving it for the networks to invent. Pixels that see the
// plane stay background in the cue frames. The board's albedo is its print
// unless an albedo map measured on the frames (support_albedo.h) replaces it:
// objects often stand on something else than the bare print.
#pragma once

#include <string>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/board.h"
#include "core/image.h"
#include "core/render/scene.h"

namespace relit::relight {

struct SupportPlane {
  bool enabled = false;
  BoardSpec board;                    // the calibrated board (cameras.json)
  double paper_albedo = 0.8;          // linear albedo of the white paper
  double ink_albedo = 0.03;           // of the printed black
  double paper_margin_m = 0.01;       // white paper around the printed squares
  Eigen::Vector3d table_albedo = Eigen::Vector3d::Constant(0.2);  // linear RGB, beyond the paper
  double table_half_size_m = 1.5;     // the table: a square of this half size
  // The board quad's measured albedo map (linear RGB EXR, rows from the
  // print's top); "" = the print. An absolute path in memory; JSON holds its
  // file name, which lives beside the JSON file (cues.json, manifest.json).
  std::string albedo_map;

  void Check(const std::string& where) const;
  nlohmann::json ToJson() const;
  // Missing or {"enabled": false} = none (files written before the plane
  // existed). `dir` is the folder of the JSON file (albedo_map's folder).
  static SupportPlane FromJson(const nlohmann::json& j, const std::string& where, const std::string& dir);
  bool operator==(const SupportPlane& o) const { return ToJson() == o.ToJson(); }
};

// Object ids of the plane's parts in cue scenes (the proxy is kProxyObjectId).
constexpr int kSupportBoardObjectId = 2;
constexpr int kSupportTableObjectId = 3;

// The board quad: the printed squares and their paper margin, centred on the
// world origin, u along the print's width and v up (world +X, +Y).
struct BoardQuad {
  double half_x_m = 0, half_y_m = 0;
  Image print_albedo;  // the print as albedo (3 channels, ~2 texels per mm, rows from its top)
};
BoardQuad MakeBoardQuad(const SupportPlane& plane);

// Adds the board (textured Lambert: the print's paper / ink, or albedo_map) and the table (Lambert,
// 0.5 mm below the paper) to a cue scene; nothing when disabled. Call before
// Commit().
void AddSupportPlane(const SupportPlane& plane, render::Scene* scene);

}  // namespace relit::relight
