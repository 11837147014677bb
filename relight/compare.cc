#include "relight/compare.h"

#include <filesystem>
#include <map>

#include <spdlog/fmt/fmt.h>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/json_file.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Training budget of one set of train.json files.
struct Budget {
  double cpu_s = 0;
  double wall_s = 0;
  bool cpu_complete = true;  // every file had process_cpu_s
  long steps = 0;
  int files = 0;

  void Add(const fs::path& train_json) {
    if (!fs::exists(train_json)) return;
    const json j = ReadJsonFile(train_json.string(), "run", 1);
    if (j.contains("skipped")) return;
    ++files;
    if (j.contains("process_cpu_s")) {
      cpu_s += j["process_cpu_s"].get<double>();
    } else {
      cpu_complete = false;
    }
    wall_s += j.value("total_s", 0.0);
    // Augment's `steps` counts from the point-light checkpoint's step.
    steps += j.value("steps", 0L) - j.value("start_step", 0L);
  }
  std::string Text() const {
    if (files == 0) return "no training";
    if (cpu_complete) return fmt::format("{:.3f} CPU-h", cpu_s / 3600);
    return fmt::format("{:.3f} h wall (no CPU time recorded)", wall_s / 3600);
  }
};

Budget WorkspaceBudget(const fs::path& workspace, bool with_augment) {
  Budget b;
  for (const char* stage : {"partitions", "augment"}) {
    if (std::string(stage) == "augment" && !with_augment) continue;
    const fs::path dir = workspace / "relight" / stage;
    if (!fs::is_directory(dir)) continue;
    std::vector<fs::path> parts;
    for (const auto& entry : fs::directory_iterator(dir)) parts.push_back(entry.path());
    std::sort(parts.begin(), parts.end());
    for (const fs::path& p : parts) b.Add(p / "train.json");
  }
  return b;
}

// The training behind an eval's "model": every partition's point-light
// training, plus the augmentation of those partitions whose augmented
// checkpoint the eval read (eval.json "models"), so a stale augment folder
// (augmentation since disabled, or not rerun) does not count. Files from
// before "models" count every augment folder.
Budget ModelBudget(const fs::path& workspace, const json& eval) {
  if (!eval.contains("models")) return WorkspaceBudget(workspace, true);
  Budget b = WorkspaceBudget(workspace, false);
  for (const json& model : eval["models"]) {
    const fs::path checkpoint = model.get<std::string>();
    if (checkpoint.empty()) continue;
    const fs::path partition_dir = checkpoint.parent_path();
    if (partition_dir.parent_path().filename() == "augment") b.Add(partition_dir / "train.json");
  }
  return b;
}

}  // namespace

CompareInput ParseCompareInput(const std::string& text) {
  const size_t eq = text.find('=');
  if (eq == std::string::npos) return {text, ""};
  return {text.substr(eq + 1), text.substr(0, eq)};
}

std::string CompareEvaluations(const std::vector<CompareInput>& inputs) {
  RELIT_REQUIRE(!inputs.empty(), "compare: give at least one --eval DIR (a folder with eval.json)");
  std::vector<std::string> types;
  struct Row {
    std::string label, steps, budget;
    std::map<std::string, std::string> cells;
  };
  std::vector<Row> rows;
  std::string truth;
  double clip = -1;  // eval.json "clip_radiance"; files from before it existed were not clipped (0)
  std::string clip_from;
  for (const CompareInput& input : inputs) {
    const fs::path path = fs::path(input.eval_dir) / "eval.json";
    RELIT_REQUIRE(fs::exists(path), "compare: ", path.string(), " is missing (run relit-relight eval --out ",
                  input.eval_dir, ")");
    const json j = ReadJsonFile(path.string(), "eval", 1);
    const std::string where = path.string();
    const std::string this_truth = JsonField(j, "truth", where).get<std::string>();
    if (truth.empty()) truth = this_truth;
    RELIT_REQUIRE(this_truth == truth, "compare: ", where, " scored against ", this_truth, ", the first against ",
                  truth, ": rows would not be comparable");
    const double this_clip = j.value("clip_radiance", 0.0);
    if (clip < 0) clip = this_clip, clip_from = where;
    RELIT_REQUIRE(this_clip == clip, "compare: ", where, " clipped radiance at ", this_clip, ", ", clip_from, " at ",
                  clip, " (0 = no clip): rows would not be comparable; re-run relit-relight eval with the same "
                  "eval.clip_radiance");
    for (const std::string& t : JsonField(j, "light_types", where).get<std::vector<std::string>>()) {
      if (std::find(types.begin(), types.end(), t) == types.end()) types.push_back(t);
    }
    const fs::path workspace = JsonField(j, "workspace", where).get<std::string>();
    const std::string variant = j.value("model_variant", std::string("dnl"));
    const std::string prefix =
        input.label.empty() ? fs::path(input.eval_dir).lexically_normal().filename().string() : input.label;
    std::map<std::string, Row> by_method;
    for (const std::string& method : JsonField(j, "methods", where).get<std::vector<std::string>>()) {
      Row row;
      if (method == "cues_only" || method == "cue_fit") {
        row.label = prefix + ": " + method;
        row.steps = "-";
        row.budget = "fit, no training";
      } else {
        const Budget b = method == "model" ? ModelBudget(workspace, j) : WorkspaceBudget(workspace, false);
        row.label = prefix + ": " + variant + (method == "model_point_light" ? " (point-light model)" : "");
        row.steps = std::to_string(b.steps);
        row.budget = b.Text();
      }
      by_method[method] = row;
    }
    for (const json& s : JsonField(j, "summary", where)) {
      const std::string method = s.at("method").get<std::string>();
      if (!by_method.count(method)) continue;
      by_method[method].cells[s.at("light_type").get<std::string>()] =
          fmt::format("{:.2f} / {:.3f} / {:.3f}", s.at("psnr_db").get<double>(), s.at("mae").get<double>(),
                      s.at("ssim").get<double>());
    }
    for (const std::string& method : JsonField(j, "methods", where).get<std::vector<std::string>>()) {
      rows.push_back(by_method[method]);
    }
  }
  std::string md = fmt::format("Truth: `{}`. Cells: PSNR (dB) / MAE / SSIM, linear, on the GT foreground, {}. "
                               "Budget: training process CPU time (train + augment).\n\n| method ({}) | steps | budget |",
                               truth,
                               clip > 0 ? fmt::format("render and truth clipped at {:g} (eval.clip_radiance)", clip)
                                        : std::string("not clipped"),
                               clip > 0 ? fmt::format("clip {:g}", clip) : std::string("no clip"));
  for (const std::string& t : types) md += " " + t + " |";
  md += " all |\n|---|---|---|";
  for (size_t i = 0; i <= types.size(); ++i) md += "---|";
  md += "\n";
  for (const Row& row : rows) {
    md += "| " + row.label + " | " + row.steps + " | " + row.budget + " |";
    for (const std::string& t : types) md += " " + (row.cells.count(t) ? row.cells.at(t) : "-") + " |";
    md += " " + (row.cells.count("all") ? row.cells.at("all") : "-") + " |\n";
  }
  return md;
}

}  // namespace relit::relight
