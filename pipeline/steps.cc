#include "pipeline/steps.h"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/json_file.h"

namespace relit::pipeline {

namespace fs = std::filesystem;

namespace {

// A stage section as hashed parameters: log_level only changes what is
// printed, so changing it does not rerun anything.
nlohmann::json Params(const YAML::Node& section) {
  nlohmann::json j = YamlToJson(section);
  if (j.is_object()) j.erase("log_level");
  return j;
}

YAML::Node Sub(const YAML::Node& section, const std::string& key) {
  if (!section.IsMap()) return YAML::Node();
  for (const auto& entry : section) {
    if (entry.first.as<std::string>() == key) return entry.second;
  }
  return YAML::Node();
}

Step MakeStep(const std::string& name, const std::string& kind) {
  Step step;
  step.name = name;
  step.kind = kind;
  return step;
}

bool IsExecutable(const std::string& path) {
  std::error_code error;
  return !path.empty() && fs::is_regular_file(path, error) && ::access(path.c_str(), X_OK) == 0;
}

}  // namespace

const std::vector<std::string>& StepKinds() {
  static const std::vector<std::string> kKinds = {"capture", "calib",  "reconstruct",
                                                  "cues",    "plan",   "train",
                                                  "augment", "render", "export",
                                                  "eval",    "report"};
  return kKinds;
}

std::string PartitionName(int index) {
  std::ostringstream s;
  s.width(2);
  s.fill('0');
  s << index;
  return s.str();
}

ToolLocator::ToolLocator(std::map<std::string, std::string> overrides, std::string self_dir)
    : overrides_(std::move(overrides)), self_dir_(std::move(self_dir)) {}

std::vector<std::string> ToolLocator::Candidates(const std::string& stage) const {
  const auto exe = StageExecutables().find(stage);
  RELIT_CHECK(exe != StageExecutables().end());
  const std::string& name = exe->second;
  std::vector<std::string> candidates;
  const auto it = overrides_.find(stage);
  if (it != overrides_.end()) {
    candidates.push_back(it->second);
    return candidates;  // an explicit path is never silently replaced
  }
  if (const char* bin = std::getenv("RELIT_BIN_DIR"); bin && *bin) {
    candidates.push_back((fs::path(bin) / name).string());
    candidates.push_back((fs::path(bin) / stage / name).string());
  }
  if (!self_dir_.empty()) {
    candidates.push_back((fs::path(self_dir_).parent_path() / stage / name).string());
    candidates.push_back((fs::path(self_dir_) / name).string());
  }
  if (const char* path = std::getenv("PATH")) {
    std::stringstream dirs(path);
    std::string dir;
    while (std::getline(dirs, dir, ':')) {
      if (!dir.empty()) candidates.push_back((fs::path(dir) / name).string());
    }
  }
  return candidates;
}

std::string ToolLocator::Find(const std::string& stage) const {
  for (const std::string& candidate : Candidates(stage)) {
    if (IsExecutable(candidate)) return fs::absolute(candidate).lexically_normal().string();
  }
  return "";
}

std::string ToolLocator::Searched(const std::string& stage) const {
  const auto it = overrides_.find(stage);
  if (it != overrides_.end()) return "tools." + stage + " = " + it->second;
  std::string text = "RELIT_BIN_DIR";
  if (!self_dir_.empty()) text += ", " + (fs::path(self_dir_).parent_path() / stage).string();
  return text + ", PATH";
}

std::string SelfDirectory() {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  return error ? "" : self.parent_path().string();
}

StepGraph::StepGraph(const PipelineConfig& config, const std::string& workspace, bool with_export,
                     bool with_augment)
    : config_(config), workspace_(workspace), with_augment_(with_augment) {
  const std::string w = workspace;
  {
    Step s = MakeStep("capture", "capture");
    s.inputs = {{"inputs.view", config.view}, {"inputs.light", config.light}};
    s.args = {"--config", "{config}", "--view", config.view, "--light", config.light};
    if (!config.geometry.empty()) {
      s.inputs.push_back({"inputs.geometry", config.geometry});
      s.args.insert(s.args.end(), {"--geometry", config.geometry});
    }
    s.args.insert(s.args.end(), {"--out", (fs::path(w) / "capture").string()});
    s.output = "capture";
    s.params = {{"capture", Params(config.capture)}};
    s.config_yaml = YamlText(config.capture);
    s.tool = "capture";
    Add(s);
  }
  {
    Step s = MakeStep("calib", "calib");
    s.deps = {"capture"};
    YAML::Node node = config.calib.IsMap() ? YAML::Clone(config.calib) : YAML::Node(YAML::NodeType::Map);
    if (config.board.IsMap()) node["board"] = YAML::Clone(config.board);
    if (!config.board_view_images.empty()) {
      node["intrinsics"]["view_board_images"] = config.board_view_images;
      s.inputs.push_back({"inputs.board_view_images", config.board_view_images});
    }
    if (!config.board_light_images.empty()) {
      node["intrinsics"]["light_board_images"] = config.board_light_images;
      s.inputs.push_back({"inputs.board_light_images", config.board_light_images});
    }
    s.args = {"--workspace", w, "--config", "{config}"};
    s.output = "calib";
    s.params = {{"calib", Params(config.calib)}, {"board", YamlToJson(config.board)}};
    s.config_yaml = YamlText(node);
    s.tool = "calib";
    Add(s);
  }
  {
    Step s = MakeStep("reconstruct", "reconstruct");
    s.deps = {"calib"};
    s.args = {"--workspace", w, "--config", "{config}"};
    if (!config.proxy_mesh.empty()) {
      s.inputs.push_back({"inputs.proxy_mesh", config.proxy_mesh});
      s.args.insert(s.args.end(), {"--mesh", config.proxy_mesh});
    }
    s.output = "reconstruct";
    s.params = {{"reconstruct", Params(config.reconstruct)}};
    s.config_yaml = YamlText(config.reconstruct);
    s.tool = "reconstruct";
    Add(s);
  }
  // The relight sub-steps all receive the whole relight: section (the
  // relight contract) but depend only on the keys listed for each.
  const std::string relight_yaml = YamlText(config.relight);
  auto relight_step = [&](const std::string& kind, std::vector<std::string> deps,
                          std::vector<std::string> keys, const std::string& output) {
    Step s = MakeStep(kind, kind);
    s.deps = std::move(deps);
    s.args = {kind, "--workspace", w, "--config", "{config}"};
    s.output = output;
    s.params = nlohmann::json::object();
    for (const std::string& key : keys) s.params["relight." + key] = Params(Sub(config.relight, key));
    s.config_yaml = relight_yaml;
    s.tool = "relight";
    return s;
  };
  Add(relight_step("cues", {"calib", "reconstruct"}, {"cues"}, "relight/cues"));
  Add(relight_step("plan", {"calib", "reconstruct"}, {"dataset", "partitions"}, "relight/plan"));
  Add(relight_step("render", {"calib", "reconstruct", "plan"}, {"render"}, "relight/render"));
  // Export also writes the interop views of the calibrated cameras.
  if (with_export) Add(relight_step("export", {"calib", "reconstruct", "plan"}, {"export"}, "relight/export"));
  // Scores against ground truth when the capture is synthetic (inputs.truth).
  if (!config.truth.empty()) {
    Step s = relight_step("eval", {"calib", "reconstruct", "cues", "plan"}, {"eval", "render"}, "relight/eval");
    s.inputs.push_back({"inputs.truth", config.truth});
    s.args.insert(s.args.end(), {"--truth", config.truth});
    Add(s);
  }
  {
    Step s = MakeStep("report", "report");
    for (const Step& other : steps_) s.deps.push_back(other.name);
    s.args = {"--workspace", w, "--config", "{config}"};
    s.output = "report";
    s.params = {{"report", Params(config.report)}};
    s.config_yaml = YamlText(config.report);
    s.tool = "report";
    Add(s);
  }
}

void StepGraph::Add(Step step) { steps_.push_back(std::move(step)); }

void StepGraph::ExpandPartitions(const std::vector<int>& partitions) {
  steps_.erase(std::remove_if(steps_.begin(), steps_.end(),
                              [](const Step& s) { return s.kind == "train" || s.kind == "augment"; }),
               steps_.end());
  std::vector<std::string> names;
  std::vector<Step> train_steps;
  for (int index : partitions) {
    Step s = MakeStep("train-" + PartitionName(index), "train");
    s.partition = index;
    s.deps = {"calib", "reconstruct", "cues", "plan"};
    s.args = {"train", "--workspace", workspace_, "--config", "{config}", "--partition",
              std::to_string(index)};
    s.output = "relight/partitions/" + PartitionName(index);
    s.params = nlohmann::json::object();
    for (const char* key : {"model", "train", "partitions", "dataset"}) {
      s.params[std::string("relight.") + key] = Params(Sub(config_.relight, key));
    }
    s.config_yaml = YamlText(config_.relight);
    s.tool = "relight";
    names.push_back(s.name);
    train_steps.push_back(std::move(s));
  }
  // Augmentation fine-tunes each partition after every partition is trained:
  // its targets come from the blend of the point-light models.
  std::vector<std::string> train_names = names;
  if (with_augment_) {
    for (int index : partitions) {
      Step s = MakeStep("augment-" + PartitionName(index), "augment");
      s.partition = index;
      s.deps = {"calib", "reconstruct", "cues", "plan"};
      s.deps.insert(s.deps.end(), train_names.begin(), train_names.end());
      s.args = {"augment", "--workspace", workspace_, "--config", "{config}", "--partition",
                std::to_string(index)};
      s.output = "relight/augment/" + PartitionName(index);
      s.params = nlohmann::json::object();
      for (const char* key : {"augment", "train"}) {
        s.params[std::string("relight.") + key] = Params(Sub(config_.relight, key));
      }
      s.config_yaml = YamlText(config_.relight);
      s.tool = "relight";
      names.push_back(s.name);
      train_steps.push_back(std::move(s));
    }
  }
  // Train (and augment) steps go right after plan; the steps after them read them.
  auto plan = std::find_if(steps_.begin(), steps_.end(), [](const Step& s) { return s.name == "plan"; });
  RELIT_CHECK(plan != steps_.end());
  steps_.insert(plan + 1, train_steps.begin(), train_steps.end());
  for (Step& s : steps_) {
    if (s.kind != "render" && s.kind != "export" && s.kind != "eval" && s.kind != "report") continue;
    s.deps.erase(std::remove_if(s.deps.begin(), s.deps.end(),
                                [](const std::string& d) {
                                  return d.rfind("train-", 0) == 0 || d.rfind("augment-", 0) == 0;
                                }),
                 s.deps.end());
    s.deps.insert(s.deps.end(), names.begin(), names.end());
  }
  expanded_ = true;
}

const Step* StepGraph::Find(const std::string& name) const {
  for (const Step& s : steps_) {
    if (s.name == name) return &s;
  }
  return nullptr;
}

std::vector<std::string> StepGraph::Downstream(const std::string& name) const {
  std::set<std::string> found = {name};
  std::vector<std::string> result;
  for (const Step& s : steps_) {  // topological order: one pass suffices
    for (const std::string& d : s.deps) {
      if (found.count(d) && !found.count(s.name)) {
        found.insert(s.name);
        result.push_back(s.name);
      }
    }
  }
  return result;
}

std::vector<std::string> StepGraph::Upstream(const std::string& name) const {
  std::set<std::string> found;
  std::vector<std::string> stack = {name};
  while (!stack.empty()) {
    const Step* s = Find(stack.back());
    stack.pop_back();
    if (!s) continue;
    for (const std::string& d : s->deps) {
      if (found.insert(d).second) stack.push_back(d);
    }
  }
  std::vector<std::string> result;
  for (const Step& s : steps_) {
    if (found.count(s.name)) result.push_back(s.name);
  }
  return result;
}

std::vector<int> ReadPlanPartitions(const std::string& workspace) {
  const std::string path = (fs::path(workspace) / "relight" / "plan" / "plan.json").string();
  const nlohmann::json plan = ReadJsonFile(path, "relight_plan", 1);
  const nlohmann::json& partitions = JsonField(plan, "partitions", path);
  RELIT_REQUIRE(partitions.is_array(), path, ": 'partitions' must be an array");
  std::vector<int> indices;
  for (size_t i = 0; i < partitions.size(); ++i) {
    const int index = JsonInt(partitions[i], "index", path + ": partitions[" + std::to_string(i) + "]");
    RELIT_REQUIRE(index >= 0 && index < 100, path, ": partition index ", index,
                  " out of range [0, 99]");
    indices.push_back(index);
  }
  std::sort(indices.begin(), indices.end());
  RELIT_REQUIRE(std::adjacent_find(indices.begin(), indices.end()) == indices.end(), path,
                ": partition indices repeat");
  return indices;
}

bool SelectorMatches(const std::string& selector, const Step& step) {
  if (selector == step.name || selector == step.kind) return true;
  return selector == "relight" && step.tool == "relight";
}

bool IsKnownSelector(const std::string& selector) {
  const auto& kinds = StepKinds();
  if (selector == "relight" || std::find(kinds.begin(), kinds.end(), selector) != kinds.end()) {
    return true;
  }
  for (const std::string prefix : {"train-", "augment-"}) {
    if (selector.rfind(prefix, 0) == 0 && selector.size() == prefix.size() + 2) {
      return std::isdigit(static_cast<unsigned char>(selector[prefix.size()])) &&
             std::isdigit(static_cast<unsigned char>(selector[prefix.size() + 1]));
    }
  }
  return false;
}

}  // namespace relit::pipeline
