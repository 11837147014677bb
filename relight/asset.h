// The relightable asset: everything `render` needs, from a workspace or from
// an exported, self-contained folder (`relit-relight export`).
//
// Asset folder (manifest schema relit.asset/1, docs/formats.md):
//   manifest.json          layout, object centre/radius, training camera,
//                          cue settings (basis, light unit, bounces), per
//                          partition: model folder, network options, M
//   proxy.obj              the proxy mesh with its UV atlas (world frame, metres)
//   proxy_normals.exr      its object-space normal map, when it has one
//   support_albedo.exr     the board's measured albedo map, when the cues had one
//   partitions/KK/         checkpoint.json + model.pt (texture + networks)
//   textures/KK.exr        neural texture level 0 (5 C channels, for inspection)
//   README.md              what the folder is and how to render it
// Rendering from the folder and from the workspace run the same code and give
// bit-identical images (relight_stage_test).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/atomic_output.h"
#include "core/camera.h"
#include "relight/partitions.h"
#include "relight/support_plane.h"

namespace relit {
class RunRecord;
}

namespace relit::relight {

// The object and its layout come from the plan (ObjectLayout).
struct AssetDescription : ObjectLayout {
  static constexpr const char* kKind = "asset";
  static constexpr int kVersion = 1;
  Intrinsics camera;                 // the training (undistorted) camera
  double capture_distance_m = 0;     // mean camera distance of the capture
  double flash_intensity = 1;        // W/sr of the cue light = the unit of light intensities
  int cue_max_depth = 4;             // bounces the cues were rendered with
  std::string mesh;                  // absolute path of the proxy mesh
  std::string normal_map;            // absolute path of its normal map ("" = none)
  // Absolute path of the proxy's fitted cue weights (cues.secondary_material
  // fitted: what the proxy wears past the primary hit); "" = the basis.
  std::string cue_weights;
  SupportPlane support_plane;        // context geometry of every cue scene (support_plane.h)
  std::vector<std::string> partition_models;  // absolute checkpoint folders; "" = not trained
};

// Which trained models of a workspace to use per partition.
enum class ModelSet {
  kFinal,       // the augmented model (W/relight/augment/KK) when present and fine-tuned from the
                // current point-light model (a stale one is skipped, with a warning), else the point-light one
  kPointLight,  // only the point-light models of W/relight/partitions/KK (before augmentation)
};

// From W/relight/{plan,cues,partitions,augment}. Throws when the plan or cues are missing.
AssetDescription DescribeWorkspace(const std::string& workspace, ModelSet models = ModelSet::kFinal);
// The models render, export and eval use: the final ones while augmentation
// is on, else the point-light ones, so that an augment folder left from
// before `augment.enabled: false` is not used.
inline ModelSet FinalModels(bool augment_enabled) {
  return augment_enabled ? ModelSet::kFinal : ModelSet::kPointLight;
}
// From an exported folder. Throws relit::Error naming the file.
AssetDescription ReadAsset(const std::string& dir);

// Writes the asset folder `out_dir` (atomically) from a workspace. `guard`
// (a user's --out) applies the output-folder rule to `out_dir`.
void ExportAsset(const std::string& workspace, const std::string& out_dir, RunRecord& record,
                 const OutputGuard* guard = nullptr, ModelSet models = ModelSet::kFinal);

}  // namespace relit::relight
