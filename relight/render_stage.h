// `relit-relight render`: new views under new lights from the trained
// partitions, through the same path as training (cue frame -> models ->
// barycentric blend of the view direction's partitions in linear HDR).
//
// Without --views it renders the configured turntables (RenderStageOptions)
// into W/relight/render/: turntable_point/NNNN.{exr,png}, turntable_env/...,
// an MP4 per turntable (composited over grey) and render.json.
// With --views FILE (JSON, see docs/relight.md) it renders the listed
// cameras x lights into --out DIR: NAME.exr (linear premultiplied RGBA) and
// NAME.png (sRGB, straight alpha).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/image.h"
#include "core/render/scene.h"
#include "relight/asset.h"
#include "relight/cue_frames.h"
#include "relight/model.h"
#include "relight/partitions.h"
#include "relight/stage_options.h"

namespace relit {
class RunRecord;
}

namespace relit::relight {

// The trained partitions of a workspace or an exported asset, ready to render.
class RelitRenderer {
 public:
  // Loads the proxy mesh and every trained partition of `asset`
  // (DescribeWorkspace or ReadAsset). Throws relit::Error when none is trained.
  explicit RelitRenderer(const AssetDescription& asset, const std::string& device = "");

  // Premultiplied linear RGBA of `camera` under `light` (light intensities
  // in the cues' units, see cues.flash_intensity).
  Image Render(const Camera& camera, const CueLight& light, const CueRenderSettings& settings);
  // The same for a cue frame rendered elsewhere (e.g. with scene()), seen
  // from `camera_centre_m` (which picks the partitions).
  Image RenderCues(const Image& cue_frame, const Eigen::Vector3d& camera_centre_m);
  // The proxy scene the cues are rendered on.
  render::Scene& scene() { return *scene_; }

  const AssetDescription& asset() const { return asset_; }
  // The light input every loaded model reads (they must agree).
  const CueFormat& format() const { return format_; }
  // Partitions weights for a view direction after dropping untrained ones.
  std::vector<std::pair<int, double>> Weights(const Eigen::Vector3d& direction) const;

 private:
  AssetDescription asset_;
  PartitionLayout layout_;
  std::unique_ptr<render::Scene> scene_;
  std::vector<std::optional<DnlModel>> models_;
  CueFormat format_;
};

// A light from JSON: {"type": "point", "position_m": [..], "intensity": x or [r,g,b]},
// {"type": "directional", "direction_to_light": [..], "irradiance": ..},
// {"type": "environment", "map": "file.exr" | "procedural:sky" | "procedural:studio",
//  "scale": 1, "rotation_deg": 0}, {"type": "area", "corner_m", "edge_u_m",
// "edge_v_m", "radiance"}. Relative map paths are resolved against `base_dir`.
CueLight LightFromJson(const nlohmann::json& j, const std::string& base_dir, const std::string& where);

// Writes NAME.exr (premultiplied linear RGBA) and NAME.png (sRGB, straight alpha).
void WriteRgba(const std::string& path_without_extension, const Image& rgba);

void RunRenderStage(const std::string& workspace, const RenderStageOptions& options, RunRecord& record,
                    ModelSet models = ModelSet::kFinal);
// Renders the views of `views_json` with `asset` into `out_dir`. Every view
// is checked first (unique plain names, valid cameras and lights, at least
// one view); `out_dir` follows the output-folder rule (OutputGuard, marker
// "relit-render"; `force` = --force).
void RunRenderViews(const AssetDescription& asset, const std::string& views_json, const std::string& out_dir,
                    const RenderStageOptions& options, RunRecord& record, const std::string& device = "",
                    bool force = false);

// `relit-render --asset DIR --views FILE --out DIR`: renders from an exported
// asset alone (no workspace).
int RunRender(int argc, char** argv);

}  // namespace relit::relight
