#include "pipeline/config.h"

#include <filesystem>
#include <fstream>
#include <iterator>

#include "core/board.h"
#include "core/error.h"
#include "pipeline/steps.h"

namespace relit::pipeline {

namespace fs = std::filesystem;

namespace {

// A path from pipeline.yaml, relative to its folder; "" stays "".
std::string Resolve(const std::string& base_dir, const std::string& path) {
  if (path.empty()) return "";
  fs::path p(path);
  if (p.is_relative()) p = fs::path(base_dir) / p;
  return p.lexically_normal().string();
}

const YAML::Node Section(const YAML::Node& root, const std::string& key) {
  if (!root.IsMap()) return YAML::Node();
  for (const auto& entry : root) {
    if (entry.first.IsScalar() && entry.first.Scalar() == key) return entry.second;
  }
  return YAML::Node();
}

}  // namespace

RELIT_OPTION_FIELDS(SlurmResources,
    .Add("partition", &S::partition, "`--partition` (\"\" = the cluster's default)")
    .Add("account", &S::account, "`--account` (\"\" = none)")
    .Add("cpus", &S::cpus, 1, 100000, "`--cpus-per-task`")
    .Add("memory", &S::memory, "`--mem`")
    .Add("gpus", &S::gpus, 0, 1024, "`--gres gpu:N` when above 0")
    .Add("time", &S::time, "`--time`")
    .Add("extra_args", &S::extra_args, "appended to sbatch as given"))

RELIT_OPTION_FIELDS(SlurmOptions,
    .Add("steps", &S::steps, StepKinds(), "step kinds submitted with sbatch; the others run on this host")
    .Add("poll_s", &S::poll_s, 0.05, 3600.0, "squeue polling interval, seconds")
    .Add("sbatch", &S::sbatch, "the sbatch command (e.g. a full path)")
    .Add("squeue", &S::squeue, "the squeue command")
    .Add("scontrol", &S::scontrol, "the scontrol command")
    .Add("sacct", &S::sacct, "the sacct command")
    .Add("scancel", &S::scancel, "the scancel command")
    .Section("resources", &S::defaults))

void SlurmOptions::Read(OptionsReader& r) {
  for (const std::string& kind : StepKinds()) r.Ignore(kind);  // read below, over the defaults
  ReadOptions(r, this);
  for (const std::string& kind : StepKinds()) {
    if (!r.Has(kind)) continue;
    OptionsReader child = r.Child(kind);
    SlurmResources resources_for_kind = defaults;
    ReadOptions(child, &resources_for_kind);
    per_kind[kind] = resources_for_kind;
  }
}

const SlurmResources& SlurmOptions::For(const std::string& kind) const {
  const auto it = per_kind.find(kind);
  return it == per_kind.end() ? defaults : it->second;
}

RELIT_OPTION_FIELDS(PipelineInputs,
    .Add("view", &S::view, "required: phone V video (filmed without flash: the camera)")
    .Add("light", &S::light, "required: phone L video (filmed with its flash on: the moving light)")
    .Add("geometry", &S::geometry, "geometry-pass video or folder of photos (`relit-capture --geometry`)")
    .Add("board_view_images", &S::board_view_images,
         "folder of phone V board-clip frames (PNG/JPEG at the capture resolution): its lens is calibrated "
         "once and kept fixed (docs/calib.md)")
    .Add("board_light_images", &S::board_light_images, "the same for phone L")
    .Add("proxy_mesh", &S::proxy_mesh,
         "a proxy mesh (OBJ/PLY, board frame, metres) passed to `relit-reconstruct --mesh` instead of its own")
    .Add("truth", &S::truth,
         "`truth.json` of a synthetic capture (relit-synth): adds the `eval` step (held-out views x lights)"))

RELIT_OPTION_FIELDS(RunSettings,
    .Add("jobs", &S::jobs, 1, 1024,
         "steps run locally at once; only the partitions' training steps are independent and each uses "
         "every core, so more than one job pays only with many cores (or GPUs)")
    .Add("executor", &S::executor, {"local", "slurm"}, "where the steps run (`slurm:` below)")
    .Add("export", &S::export_mode, {"auto", "on", "off"},
         "whether the pipeline has the export step (auto: when `relit-relight --help` lists it)"))

const std::map<std::string, std::string>& StageExecutables() {
  static const std::map<std::string, std::string> kExecutables = {
      {"capture", "relit-capture"}, {"calib", "relit-calib"},   {"reconstruct", "relit-reconstruct"},
      {"relight", "relit-relight"}, {"report", "relit-report"}};
  return kExecutables;
}

PipelineConfig PipelineConfig::Load(const std::string& path) {
  std::error_code error;
  RELIT_REQUIRE(fs::is_regular_file(path, error), "pipeline file ", path,
                " does not exist (relit init writes a commented template)");
  std::ifstream in(path);
  RELIT_REQUIRE(in, "cannot read ", path);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const fs::path absolute = fs::absolute(path).lexically_normal();
  return FromString(text, path, absolute.parent_path().string());
}

PipelineConfig PipelineConfig::FromString(const std::string& text, const std::string& file,
                                          const std::string& base_dir) {
  const YAML::Node root = LoadYaml(text, file);
  RELIT_REQUIRE(root.IsMap() || root.IsNull(), file,
                ": expected a mapping of sections (inputs, board, capture, ...) at the top");
  PipelineConfig config;
  config.file = fs::absolute(file).lexically_normal().string();
  config.base_dir = base_dir;
  OptionsReader r(root, file);

  OptionsReader inputs = r.Child("inputs");
  ReadOptions(inputs, static_cast<PipelineInputs*>(&config));
  RELIT_REQUIRE(!config.view.empty(), inputs.Where("view"),
                ": inputs.view is required (phone V video, filmed without flash)");
  RELIT_REQUIRE(!config.light.empty(), inputs.Where("light"),
                ": inputs.light is required (phone L video, filmed with the flash on)");
  for (std::string* p : {&config.view, &config.light, &config.geometry, &config.board_view_images,
                         &config.board_light_images, &config.proxy_mesh, &config.truth}) {
    *p = Resolve(base_dir, *p);
  }

  OptionsReader board = r.Child("board");
  BoardSpec spec;
  ReadBoardSpec(board, &spec);
  config.board = Section(root, "board");

  OptionsReader tools = r.Child("tools");
  for (const auto& [stage, executable] : StageExecutables()) {
    std::string tool;
    tools.Read(stage, &tool);
    if (!tool.empty()) config.tools[stage] = Resolve(base_dir, tool);
  }
  tools.Finish();

  OptionsReader run = r.Child("run");
  ReadOptions(run, static_cast<RunSettings*>(&config));

  OptionsReader slurm = r.Child("slurm");
  config.slurm.Read(slurm);

  config.capture = Section(root, "capture");
  config.calib = Section(root, "calib");
  config.reconstruct = Section(root, "reconstruct");
  config.relight = Section(root, "relight");
  config.report = Section(root, "report");
  for (const char* stage : {"capture", "calib", "reconstruct", "relight", "report"}) {
    // Not Child(): Finish() would then walk the stage's keys, which only the
    // stage knows (stage_check.cc reads them with the stage's reader).
    const YAML::Node section = Section(root, stage);
    RELIT_REQUIRE(!section.IsDefined() || section.IsNull() || section.IsMap(), r.Where(stage),
                  ": '", stage, "' must be a mapping of the stage's options");
    r.Ignore(stage);
  }
  r.Finish();  // unknown top-level keys

  internal::CheckStageSections(config, root);
  return config;
}

nlohmann::json YamlToJson(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return nullptr;
  if (node.IsScalar()) return node.Scalar();
  if (node.IsSequence()) {
    nlohmann::json array = nlohmann::json::array();
    for (const auto& item : node) array.push_back(YamlToJson(item));
    return array;
  }
  nlohmann::json object = nlohmann::json::object();
  for (const auto& entry : node) object[entry.first.as<std::string>()] = YamlToJson(entry.second);
  return object;
}

std::string YamlText(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull() || (node.IsMap() && node.size() == 0)) return "{}\n";
  YAML::Emitter out;
  out << node;
  return std::string(out.c_str()) + "\n";
}

}  // namespace relit::pipeline
