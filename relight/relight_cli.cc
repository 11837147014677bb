#include <filesystem>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/log.h"
#include "core/options.h"
#include "core/run_record.h"
#include "core/atomic_output.h"
#include "relight/asset.h"
#include "relight/augment.h"
#include "relight/checkpoint.h"
#include "relight/compare.h"
#include "relight/cue_stage.h"
#include "relight/eval.h"
#include "relight/interop.h"
#include "relight/plan.h"
#include "relight/relight_options.h"
#include "relight/render_stage.h"
#include "relight/train_stage.h"

namespace relit::relight {

namespace fs = std::filesystem;




namespace {

// Every trained checkpoint (point-light and augmented) against the config's
// cues.input / cues.bases. Without a plan there is nothing to check yet (the
// steps say what to run).
void RequireWorkspaceFormat(const std::string& workspace, const CueFormat& configured) {
  const fs::path root(workspace);
  if (!fs::exists(root / "relight/plan/plan.json") || !fs::exists(root / "relight/cues/cues.json")) return;
  for (ModelSet set : {ModelSet::kPointLight, ModelSet::kFinal}) {
    for (const std::string& model : DescribeWorkspace(workspace, set).partition_models) {
      if (!model.empty()) RequireCheckpointFormat(model, configured);
    }
  }
}

}  // namespace

int RunRelight(int argc, char** argv) {
  CLI::App app{"relit-relight: Deferred Neural Lighting on a calibrated, reconstructed workspace. Steps: cues "
               "-> plan -> train --partition K (each partition independently) -> render, export. See docs/relight.md."};
  app.require_subcommand(1);
  std::string workspace, config, log_level, views, out;
  int partition = -1;
  bool restart = false;
  auto common = [&](CLI::App* sub) {
    sub->add_option("--workspace", workspace, "workspace folder W")->required();
    sub->add_option("--config", config, "YAML file with the relight section (unknown keys are errors)")
        ->check(CLI::ExistingFile);
    sub->add_option("--log-level", log_level, "trace | debug | info | warn | error");
  };
  CLI::App* cues = app.add_subcommand("cues", "render the radiance cues of every training frame");
  CLI::App* plan = app.add_subcommand("plan", "split frames into training/validation and partitions");
  CLI::App* train = app.add_subcommand("train", "train one partition (resumes from its checkpoint)");
  CLI::App* augment = app.add_subcommand("augment", "lighting augmentation: fine-tune one partition under "
                                          "environment maps (after every partition is trained)");
  CLI::App* render = app.add_subcommand("render", "render turntables, or the views of a --views JSON file");
  CLI::App* export_asset = app.add_subcommand("export", "write the self-contained relightable asset folder");
  CLI::App* eval = app.add_subcommand("eval", "score the trained workspace against a synthetic capture's ground "
                                      "truth (truth.json's eval set)");
  for (CLI::App* sub : {cues, plan, train, augment, render, export_asset, eval}) common(sub);
  CLI::App* compare = app.add_subcommand("compare", "one Markdown table from several workspaces' eval.json "
                                         "(methods x light types, with training CPU-hours)");
  std::vector<std::string> compare_evals;
  compare->add_option("--eval", compare_evals, "[LABEL=]DIR with eval.json (repeat)")->required();
  compare->add_option("--out", out, "write the table here (default: print it)");
  std::string truth;
  eval->add_option("--truth", truth, "relit-synth's truth.json (with its eval/ folder)")->required();
  eval->add_option("--out", out, "output folder (default W/relight/eval)");
  export_asset->add_option("--out", out, "asset folder (default W/relight/export)");
  InteropOptions interop;
  bool no_interop = false;
  export_asset->add_flag("--no-interop", no_interop, "skip the interop exports (OUT/interop: COLMAP, NeRF, glTF)");
  export_asset->add_option("--bake-views", interop.bake_views, "glTF preview bake: renders around the object")
      ->capture_default_str();
  export_asset->add_option("--bake-texture-px", interop.bake_texture_px, "glTF preview texture size (power of two)")
      ->capture_default_str();
  export_asset->add_option("--bake-width-px", interop.bake_width_px,
                           "bake render width (multiple of 4; 0 = the training size)")
      ->capture_default_str();
  export_asset->add_option("--bake-samples-per-pixel", interop.bake_samples_per_pixel,
                           "cue paths per bake pixel (0 = as the cues)")
      ->capture_default_str();
  export_asset->add_option("--bake-exposure", interop.bake_exposure, "linear scale before the texture's sRGB encoding")
      ->capture_default_str();
  train->add_option("--partition", partition, "partition index K (see plan.json)")->required();
  train->add_flag("--restart", restart, "discard the checkpoint and start over");
  augment->add_option("--partition", partition, "partition index K (see plan.json)")->required();
  augment->add_flag("--restart", restart, "discard the augmented frames and checkpoint and start over");
  render->add_option("--views", views, "JSON file of cameras and lights to render (docs/relight.md)")
      ->check(CLI::ExistingFile);
  render->add_option("--out", out, "output folder for --views");
  bool force = false;
  for (CLI::App* sub : {render, eval, export_asset}) {
    sub->add_flag("--force", force, "replace an --out folder that relit did not write (never one holding an input)");
  }
  CLI11_PARSE(app, argc, argv);
  if (compare->parsed()) {
    std::vector<CompareInput> inputs;
    for (const std::string& e : compare_evals) inputs.push_back(ParseCompareInput(e));
    const std::string table = CompareEvaluations(inputs);
    if (out.empty()) {
      std::fputs(table.c_str(), stdout);
    } else {
      AtomicWriteFile(out, table);
    }
    return 0;
  }
  RelightOptions options;
  if (!config.empty()) {
    OptionsReader reader = OptionsReader::FromFile(config);
    options = ReadRelightSection(reader);
  }
  options.workspace = workspace;
  // Export flags given on the command line win over the config's `export:`.
  for (const auto& [flag, apply] : std::initializer_list<std::pair<const char*, std::function<void()>>>{
           {"--no-interop", [&] { options.exports.enabled = !no_interop; }},
           {"--bake-views", [&] { options.exports.bake_views = interop.bake_views; }},
           {"--bake-texture-px", [&] { options.exports.bake_texture_px = interop.bake_texture_px; }},
           {"--bake-width-px", [&] { options.exports.bake_width_px = interop.bake_width_px; }},
           {"--bake-samples-per-pixel", [&] { options.exports.bake_samples_per_pixel = interop.bake_samples_per_pixel; }},
           {"--bake-exposure", [&] { options.exports.bake_exposure = interop.bake_exposure; }}}) {
    if (export_asset->count(flag) > 0) apply();
  }
  if (!log_level.empty()) options.log_level = log_level;
  const spdlog::level::level_enum level = ParseLogLevel(options.log_level);
  SetVerbosity(level);
  RELIT_REQUIRE(!workspace.empty(), "relight: --workspace is required");
  RELIT_REQUIRE(fs::is_directory(workspace), "relight: workspace ", workspace, " is not a folder");
  CheckOptions(options);
  const fs::path relight_dir = fs::path(workspace) / "relight";
  // Augmentation off: render, export and eval use the point-light models,
  // even where an augment folder of an earlier run is still current.
  const ModelSet models = FinalModels(options.augment.enabled);
  if (!options.augment.enabled && fs::is_directory(relight_dir / "augment") &&
      (render->parsed() || eval->parsed() || export_asset->parsed())) {
    spdlog::info("augment.enabled is false: the point-light models are used, not {} (delete it to free the space)",
                 (relight_dir / "augment").string());
  }
  RunRecord record("relit-relight");
  record.SetCommandLine(argc, argv);
  record.SetOptions(OptionsToJson(options));
  // A trained model must read the light input the config describes.
  if (augment->parsed() || render->parsed() || eval->parsed() || export_asset->parsed()) {
    RequireWorkspaceFormat(workspace, options.cues.Format());
  }
  if (cues->parsed()) {
    LogFileScope log((relight_dir / "logs" / "cues.log").string(), level);
    RunCueStage(workspace, options.cues, record);
  } else if (plan->parsed()) {
    LogFileScope log((relight_dir / "logs" / "plan.log").string(), level);
    RunPlanStage(workspace, options.dataset, options.partitions, record);
  } else if (train->parsed()) {
    const std::string name = "train_" + PartitionDirName(std::max(partition, 0)) + ".log";
    LogFileScope log((relight_dir / "logs" / name).string(), level);
    const TrainStageResult result = RunTrainStage(workspace, partition, options.model, options.train, restart, record);
    if (result.interrupted) return 130;
  } else if (augment->parsed()) {
    const std::string name = "augment_" + PartitionDirName(std::max(partition, 0)) + ".log";
    LogFileScope log((relight_dir / "logs" / name).string(), level);
    const AugmentStageResult result = RunAugmentStage(workspace, partition, options.augment, options.train, restart, record);
    if (result.interrupted) return 130;
  } else if (render->parsed()) {
    if (!views.empty()) {
      RELIT_REQUIRE(!out.empty(), "render --views needs --out DIR");
      RunRenderViews(DescribeWorkspace(workspace, models), views, out, options.render, record, "", force);
    } else {
      LogFileScope log((relight_dir / "logs" / "render.log").string(), level);
      RunRenderStage(workspace, options.render, record, models);
    }
  } else if (eval->parsed()) {
    LogFileScope log((relight_dir / "logs" / "eval.log").string(), level);
    const OutputGuard guard{"relit-relight eval", force, {workspace, truth}};
    RunEval(workspace, truth, out.empty() ? (relight_dir / "eval").string() : out, options.eval, options.render,
            record, out.empty() ? nullptr : &guard, models);
  }
  if (export_asset->parsed()) {
    LogFileScope log((relight_dir / "logs" / "export.log").string(), level);
    const std::string asset_dir = out.empty() ? (relight_dir / "export").string() : out;
    const OutputGuard guard{"relit-relight export", force, {workspace}};
    ExportAsset(workspace, asset_dir, record, out.empty() ? nullptr : &guard, models);
    if (options.exports.enabled) {
      ExportInterop(workspace, (fs::path(asset_dir) / "interop").string(), options.exports, record, models);
      record.Write((fs::path(asset_dir) / "export.json").string());  // now with what interop/ holds
    }
  }
  return 0;
}

}  // namespace relit::relight
