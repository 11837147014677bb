// Scene presets of relit-synth: the object(s) standing on a printed ChArUco
// board lying on a table, with ground-truth geometry and materials.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/board.h"
#include "core/image.h"
#include "core/render/scene.h"

namespace relit::synth {

// Object ids in the renderer's AOVs: foreground objects (what relit
// reconstructs and what the alpha mattes cover) count from 1.
constexpr int kBoardObjectId = 100;
constexpr int kTableObjectId = 101;

struct SynthObject {
  std::string name;
  int object_id = 0;
  bool foreground = true;            // counted in the alpha mattes
  render::TriangleMesh mesh;          // world frame, metres
  render::Material material;
  // Ground-truth description of `material` (textures referenced by name in
  // `textures`, which hold the exact linear images the renderer used).
  nlohmann::json material_json;
  std::map<std::string, Image> textures;
};

struct SynthScene {
  std::string preset;
  std::vector<SynthObject> objects;
  Eigen::Vector3d target_world = Eigen::Vector3d::Zero();  // centre of the foreground's bounds
  double foreground_radius_m = 0;                          // bounding-sphere radius about target
  BoardSpec board;
  cv::Mat board_image;               // printed board, 8-bit grey, with white margin
  double board_pixels_per_metre = 0;
  int board_margin_px = 0;

  // Adds all objects (geometry + materials) to a render scene; no lights.
  void AddTo(render::Scene* scene) const;
  std::vector<int> ForegroundIds() const;
};

// Presets: "spot" (textured diffuse cow with glossy painted patches),
// "bunny" (glossy, fine geometry), "spheres" (glossy sphere + diffuse sphere
// on a rough-glossy tile: strong interreflection), "mesh" (any OBJ/PLY:
// with UVs it gets a procedural colour texture and glossy painted patches,
// without UVs a uniform glossy paint).
std::vector<std::string> PresetNames();

// A user mesh for the "mesh" preset.
struct CustomMesh {
  std::string path;        // .obj or .ply
  double height_m = 0.12;  // scaled to this height, standing on the board centre
  bool y_up = true;        // false: the file is already Z-up
};

// `assets_dir` holds spot.obj, spot_texture.png and bunny.obj.
SynthScene BuildScene(const std::string& preset, const BoardSpec& board,
                      const std::string& assets_dir, const CustomMesh& custom = {});

// The matte board: a quad in the z = 0 plane, textured with the printed board
// (including its white margin) so that texture pixels land exactly where
// CharucoCornersWorld() puts the corners.
SynthObject MakeBoardObject(const BoardSpec& board, double pixels_per_metre, int margin_px,
                            cv::Mat* board_image);

// Compiled-in default location of the assets (the source tree).
std::string DefaultAssetsDir();

}  // namespace relit::synth
