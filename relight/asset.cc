#include "relight/asset.h"

#include <filesystem>

#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/run_record.h"
#include "core/stage_run.h"
#include "relight/augment.h"
#include "relight/checkpoint.h"
#include "relight/sh_encoding.h"
#include "relight/cue_stage.h"
#include "relight/dataset.h"
#include "relight/plan.h"
#include "relight/train_stage.h"

namespace relit::relight {

namespace fs = std::filesystem;

using nlohmann::json;

AssetDescription DescribeWorkspace(const std::string& workspace, ModelSet models) {
  const fs::path root = fs::absolute(workspace);
  const Plan plan = ReadPlan((root / "relight" / "plan" / "plan.json").string());
  const std::string cues_path = (root / "relight" / "cues" / "cues.json").string();
  RELIT_REQUIRE(fs::exists(cues_path), cues_path, " is missing: run `relit-relight cues` first");
  const CuesFile cues = ReadCuesFile(cues_path);
  AssetDescription asset;
  static_cast<ObjectLayout&>(asset) = plan;
  asset.camera = cues.camera;
  asset.flash_intensity = cues.flash_intensity;
  asset.cue_max_depth = cues.max_depth;
  asset.mesh = (root / cues.mesh).string();
  if (!cues.normal_map.empty()) asset.normal_map = (root / cues.normal_map).string();
  if (!cues.cue_weights.empty()) asset.cue_weights = (root / cues.cue_weights).string();
  asset.support_plane = cues.support_plane;
  double distance = 0;
  for (const CueFrameRecord& f : cues.frames) {
    distance += (f.cam_from_world.Inverse().translation - plan.object_centre_m).norm();
  }
  asset.capture_distance_m = distance / std::max<size_t>(1, cues.frames.size());
  for (size_t p = 0; p < plan.partitions.size(); ++p) {
    const std::string name = PartitionDirName(static_cast<int>(p));
    auto trained = [](const fs::path& dir) {
      return fs::exists(dir / "train.json") && fs::exists(dir / "checkpoint" / "checkpoint.json");
    };
    const fs::path augmented = root / "relight" / "augment" / name, point = root / "relight" / "partitions" / name;
    bool use_augmented = models == ModelSet::kFinal && trained(augmented);
    if (use_augmented && !AugmentedFromCurrentModel(augmented.string(), point.string())) {
      spdlog::warn("{} was fine-tuned from another point-light model than {} (stale): using the point-light "
                   "model; run relit-relight augment again for this partition, or delete the folder",
                   augmented.string(), (point / "checkpoint").string());
      use_augmented = false;
    }
    if (use_augmented) {
      asset.partition_models.push_back((augmented / "checkpoint").string());
    } else {
      asset.partition_models.push_back(trained(point) ? (point / "checkpoint").string() : "");
    }
  }
  return asset;
}

AssetDescription ReadAsset(const std::string& dir) {
  const fs::path root = fs::absolute(dir);
  const std::string path = (root / "manifest.json").string();
  RELIT_REQUIRE(fs::exists(path), path, " is missing: not a relit asset folder (make one with relit-relight export)");
  const json j = ReadJsonFile(path, AssetDescription::kKind, AssetDescription::kVersion);
  AssetDescription asset;
  ReadObjectLayout(j, path, &asset);
  asset.camera = IntrinsicsFromJson(JsonField(j, "camera", path), path + ": camera");
  asset.capture_distance_m = JsonNumber(j, "capture_distance_m", path);
  const json& cues = JsonField(j, "cues", path);
  asset.flash_intensity = JsonNumber(cues, "light_unit_w_per_sr", path);
  asset.cue_max_depth = JsonInt(cues, "max_depth", path);
  asset.support_plane = SupportPlane::FromJson(cues.value("support_plane", json()), path, root.string());
  asset.mesh = (root / JsonField(j, "mesh", path).get<std::string>()).string();
  if (j.contains("normal_map")) asset.normal_map = (root / JsonString(j, "normal_map", path)).string();
  if (cues.contains("cue_weights")) asset.cue_weights = (root / JsonString(cues, "cue_weights", path)).string();
  for (const json& p : JsonField(j, "partitions", path)) {
    const std::string model = p.value("model", std::string());
    asset.partition_models.push_back(model.empty() ? "" : (root / model).string());
  }
  return asset;
}

void ExportAsset(const std::string& workspace, const std::string& out_dir, RunRecord& record,
                 const OutputGuard* guard, ModelSet models) {
  const AssetDescription asset = DescribeWorkspace(workspace, models);
  const Plan plan = ReadPlan((fs::path(workspace) / "relight" / "plan" / "plan.json").string());
  StageRun out(guard ? AtomicDir(out_dir, *guard) : AtomicDir(out_dir), record, "export.json");
  const fs::path root = out.path();
  fs::copy_file(asset.mesh, root / "proxy.obj");
  if (!asset.normal_map.empty()) fs::copy_file(asset.normal_map, root / "proxy_normals.exr");
  if (!asset.cue_weights.empty()) fs::copy_file(asset.cue_weights, root / "proxy_cue_weights.exr");
  if (!asset.support_plane.albedo_map.empty()) {  // the manifest names it by file name (SupportPlane::ToJson)
    fs::copy_file(asset.support_plane.albedo_map, root / fs::path(asset.support_plane.albedo_map).filename());
  }
  json partitions = json::array();
  int trained = 0;
  CueFormat format;
  for (size_t p = 0; p < asset.partition_models.size(); ++p) {
    const std::string name = PartitionDirName(static_cast<int>(p));
    json entry = {{"index", p}, {"direction", ToJson(plan.partitions[p].direction)}};
    if (!asset.partition_models[p].empty()) {
      const fs::path source = asset.partition_models[p];
      const fs::path target = root / "partitions" / name;
      fs::create_directories(target);
      // Only what rendering needs: no optimiser state.
      for (const char* file : {"checkpoint.json", "model.pt"}) fs::copy_file(source / file, target / file);
      const CheckpointInfo info = ReadCheckpointInfo(source);
      DnlModel model = LoadModel(source, "cpu");
      fs::create_directories(root / "textures");
      format = model->options().format;
      std::vector<std::string> channels;
      const int per_basis = model->options().channels_per_basis;
      if (format.is_sh()) {  // SH-modulated channels, then the pass-through ones
        for (const std::string& n : ShLightChannelNames()) channels.push_back("tex_" + n);
        for (int c = 0; c < per_basis; ++c) channels.push_back("pass.ch" + std::to_string(c));
      } else {
        for (size_t c = 0; c < format.bases.size() * per_basis; ++c) {
          channels.push_back("basis" + std::to_string(c / per_basis) + ".ch" + std::to_string(c % per_basis));
        }
      }
      WriteImage((root / "textures" / (name + ".exr")).string(),
                 TensorToImage(model->texture()->texels().detach(), channels), PixelStorage::kFloat);
      entry["model"] = "partitions/" + name;
      entry["texture"] = "textures/" + name + ".exr";
      entry["steps"] = info.step;
      entry["model_options"] = OptionsToJson(info.model_options);
      entry["log_encoding"] = {{"formula", "y = 2 (ln(x + 1/e) + 1) / (ln(M + 1/e) + 1) - 1"},
                               {"M", info.model_options.max_radiance}};
      ++trained;
    }
    partitions.push_back(entry);
  }
  RELIT_REQUIRE(trained > 0, "export: no trained partition in ", workspace, "/relight/partitions: train first");
  json manifest = ObjectLayoutJson(asset);
  manifest.update({{"units", "metres"},
                   {"frame", "board frame: origin and x axis from the ChArUco board, +Z up (docs/conventions.md)"},
                   {"camera", ToJson(asset.camera)},
                   {"capture_distance_m", asset.capture_distance_m},
                   {"cues",
                    {{"basis", format.LongBasisNames()},
                     {"input", format.input},
                     {"roughness", "GGX alpha (no squaring), specular F0 = 1"},
                     {"light_unit_w_per_sr", asset.flash_intensity},
                     {"max_depth", asset.cue_max_depth},
                     {"support_plane", asset.support_plane.ToJson()}}},
                   {"mesh", "proxy.obj"},
                   {"partitions", partitions},
                   {"relit_version", RelitVersion()}});
  if (!asset.normal_map.empty()) manifest["normal_map"] = "proxy_normals.exr";
  if (!asset.cue_weights.empty()) manifest["cues"]["cue_weights"] = "proxy_cue_weights.exr";
  WriteJsonFile((root / "manifest.json").string(), AssetDescription::kKind, AssetDescription::kVersion, manifest);
  AtomicWriteFile(root / "README.md",
                  "# relit relightable asset\n\n"
                  "Deferred Neural Lighting asset exported by relit " + std::string(RelitVersion()) + ".\n\n"
                  "- `manifest.json`: layout of the view partitions, object centre, training camera, the radiance-cue\n"
                  "  settings (5 basis materials, light unit, bounces) and, per partition, its network options and\n"
                  "  the log-encoding constant M.\n"
                  "- `proxy.obj`: the proxy mesh with its UV atlas (metres, board frame, +Z up); `proxy_normals.exr`,\n"
                  "  when present: its object-space normal map (float RGB, read at the UVs).\n"
                  "- `support_albedo.exr`, when present: the board's albedo map measured on the capture (the cue\n"
                  "  scenes' support plane, see `cues.support_plane` in the manifest).\n"
                  "- `proxy_cue_weights.exr`, when present (`cues.cue_weights`): the proxy's fitted weights of the\n"
                  "  5 basis materials (float, cue0.R .. cue4.B); the cue scenes' proxy wears their mixture past the\n"
                  "  primary hit, so the cues hold the inter-reflections between its parts.\n"
                  "- `partitions/KK/`: neural texture and networks (LibTorch `model.pt` + `checkpoint.json`).\n"
                  "- `textures/KK.exr`: level 0 of each neural texture, for inspection.\n\n"
                  "Render it with `relit-render --asset THIS_FOLDER --views views.json --out DIR` (docs/relight.md\n"
                  "describes the views file: any pinhole camera, point / directional / environment / area light).\n");
  record.Set("partitions_exported", trained);
  out.Commit();
  spdlog::info("export: {} partitions -> {}", trained, out.target().string());
}

}  // namespace relit::relight
