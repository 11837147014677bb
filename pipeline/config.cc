#include "pipeline/config.h"

#include <filesystem>
#include <fstream>
#include <iterator>

#include "core/board.h"
#include "core/error.h"

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

void ReadStringVector(OptionsReader& r, const std::string& key, std::vector<std::string>* v) {
  r.Read(key, v);
}

}  // namespace

void SlurmResources::Read(OptionsReader& r) {
  r.Read("partition", &partition);
  r.Read("account", &account);
  r.ReadRange("cpus", &cpus, 1, 100000);
  r.Read("memory", &memory);
  r.ReadRange("gpus", &gpus, 0, 1024);
  r.Read("time", &time);
  ReadStringVector(r, "extra_args", &extra_args);
  r.Finish();
}

nlohmann::json SlurmResources::ToJson() const {
  return {{"partition", partition}, {"account", account}, {"cpus", cpus},   {"memory", memory},
          {"gpus", gpus},           {"time", time},       {"extra_args", extra_args}};
}

void SlurmOptions::Read(OptionsReader& r) {
  ReadStringVector(r, "steps", &steps);
  for (const std::string& kind : steps) {
    RELIT_REQUIRE(kind == "capture" || kind == "calib" || kind == "reconstruct" || kind == "cues" ||
                      kind == "plan" || kind == "train" || kind == "augment" || kind == "render" ||
                      kind == "export" || kind == "eval" || kind == "report",
                  r.Where("steps"), ": unknown step kind '", kind,
                  "' (capture, calib, reconstruct, cues, plan, train, augment, render, export, eval, report)");
  }
  r.ReadRange("poll_s", &poll_s, 0.05, 3600.0);
  r.Read("sbatch", &sbatch);
  r.Read("squeue", &squeue);
  r.Read("scontrol", &scontrol);
  r.Read("sacct", &sacct);
  r.Read("scancel", &scancel);
  OptionsReader resources = r.Child("resources");
  defaults.Read(resources);
  // Per-kind resources start from the defaults and override some keys.
  for (const char* kind : {"capture", "calib", "reconstruct", "cues", "plan", "train", "augment", "render",
                           "export", "eval", "report"}) {
    if (!r.Has(kind)) {
      r.Ignore(kind);
      continue;
    }
    OptionsReader child = r.Child(kind);
    SlurmResources resources_for_kind = defaults;
    resources_for_kind.Read(child);
    per_kind[kind] = resources_for_kind;
  }
  r.Finish();
}

const SlurmResources& SlurmOptions::For(const std::string& kind) const {
  const auto it = per_kind.find(kind);
  return it == per_kind.end() ? defaults : it->second;
}

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
  inputs.Read("view", &config.view);
  inputs.Read("light", &config.light);
  inputs.Read("geometry", &config.geometry);
  inputs.Read("board_view_images", &config.board_view_images);
  inputs.Read("board_light_images", &config.board_light_images);
  inputs.Read("proxy_mesh", &config.proxy_mesh);
  inputs.Read("truth", &config.truth);
  inputs.Finish();
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
  run.ReadRange("jobs", &config.jobs, 1, 1024);
  run.Read("executor", &config.executor);
  RELIT_REQUIRE(config.executor == "local" || config.executor == "slurm", run.Where("executor"),
                ": run.executor must be local or slurm, got '", config.executor, "'");
  run.Read("export", &config.export_mode);
  RELIT_REQUIRE(config.export_mode == "auto" || config.export_mode == "on" ||
                    config.export_mode == "off",
                run.Where("export"), ": run.export must be auto, on or off, got '",
                config.export_mode, "'");
  run.Finish();

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
