// relit-bench-relight-ladder: issue 24's error budget. On a synthetic
// capture that the pipeline has taken through reconstruct, trains and scores
// the relight stage on four rungs of inputs (bench/relight_ladder.h): true
// cameras, flash, mesh and mattes (a); calibrated cameras and flash (b);
// the stage's proxy (c); the stage's mattes (d, the whole pipeline); on
// request (--rungs ...o) rung (b) with the true mesh moved out by
// --offset-mm, what proxy accuracy the relight stage needs. Prints
// PSNR per light type per rung and what each stage costs.
//
//   relit-bench-relight-ladder --pipeline pipeline.yaml --workspace demo/workspace --out bench-out/ladder-demo
//
// The relight (and, for rungs a, b and o, reconstruct) options are the
// pipeline file's own sections, but the true mesh gets no photometric normal
// map (its normals are true); inputs.truth names the capture's truth.json.
// Each rung is a workspace OUT/rung-X (capture and calib hard-linked from
// the workspace, nothing in it written); a rerun skips finished steps, and
// refuses a rung made from other inputs or options unless --force.
// Results and how to reproduce them: docs/benchmarks.md, "Relight: error budget".
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "bench/relight_ladder.h"
#include "core/atomic_output.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/main_wrapper.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "core/shell.h"
#include "pipeline/config.h"
#include "pipeline/hash.h"
#include "pipeline/run_support.h"
#include "pipeline/steps.h"

namespace relit::bench {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

struct LadderOptions {
  std::string pipeline, workspace, out, rungs = kLadderRungs;
  double offset_mm = 1.0;  // rung o: the true mesh moved out (negative: in) by this much
  bool force = false;
};

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Runs a stage executable with its output in `log`; throws with the log's end.
void RunTool(const std::vector<std::string>& argv, const fs::path& log) {
  std::string command;
  for (const std::string& a : argv) command += (command.empty() ? "" : " ") + ShellQuote(a);
  spdlog::info("ladder: {}", command);
  const CommandResult result = RunCommand(command + " >>" + ShellQuote(log.string()) + " 2>&1 </dev/null");
  if (result.ok()) return;
  std::ifstream in(log);
  std::string line, last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  throw Error(fs::path(argv[0]).filename().string() + " " + ExitDescription(result.status) + ": " + last +
              " (whole output: " + log.string() + ")");
}

class Ladder {
 public:
  explicit Ladder(const LadderOptions& o)
      : o_(o), config_(pipeline::PipelineConfig::Load(o.pipeline)), workspace_(fs::absolute(o.workspace)),
        out_(fs::absolute(o.out)), tools_(config_.tools, pipeline::SelfDirectory()) {
    RELIT_REQUIRE(!config_.truth.empty(), o.pipeline,
                  ": inputs.truth is not set: the ladder needs a synthetic capture's truth.json");
    truth_ = ReadJsonFile(config_.truth, "synth_truth", 1);
    synth_dir_ = fs::path(config_.truth).parent_path();
    for (const char* stage : {"capture", "calib", "reconstruct"}) {
      RELIT_REQUIRE(fs::is_directory(workspace_ / stage), (workspace_ / stage).string(),
                    " is missing: run `relit run ", o.pipeline, " --workspace ", o.workspace,
                    " --to reconstruct` first");
    }
    for (const char rung : o.rungs) RungDescription(rung);  // rejects unknown letters
    fs::create_directories(out_);
    relight_config_ = out_ / "relight.yaml";
    reconstruct_config_ = out_ / "reconstruct.yaml";
    AtomicWriteFile(relight_config_, pipeline::YamlText(config_.relight));
    const YAML::Node true_mesh = TrueMeshReconstructOptions(config_.reconstruct);
    AtomicWriteFile(reconstruct_config_, pipeline::YamlText(true_mesh));
    pipeline::HashCache hashes;
    fingerprint_ = pipeline::HashJson(
        {{"relight", pipeline::YamlToJson(config_.relight)},
         {"reconstruct", pipeline::YamlToJson(config_.reconstruct)},
         {"true_mesh_reconstruct", pipeline::YamlToJson(true_mesh)},
         {"truth", hashes.HashFile(config_.truth)},
         {"cameras", hashes.HashFile(workspace_ / "calib" / "cameras.json")},
         {"lights", hashes.HashFile(workspace_ / "calib" / "lights.json")},
         {"proxy", hashes.HashFile(workspace_ / "reconstruct" / "proxy.json")}});
  }

  int Run() {
    const auto start = Clock::now();
    Progress progress("ladder", static_cast<int64_t>(o_.rungs.size()) * kStepsPerRung);
    json scores = json::object(), rungs = json::object();
    for (const char rung : o_.rungs) {
      rungs[std::string(1, rung)] = RunRung(rung, &progress);
      scores[std::string(1, rung)] = rungs[std::string(1, rung)]["scores"];
    }
    progress.Finish();
    const std::string table = LadderTable(scores);
    AtomicWriteFile(out_ / "ladder.md", table);
    WriteJsonFile((out_ / "ladder.json").string(), "ladder", 1,
                  {{"tool", "relit-bench-relight-ladder"},
                   {"date", CurrentTimeIso8601Utc()},
                   {"options", {{"pipeline", fs::absolute(o_.pipeline).string()},
                                {"workspace", workspace_.string()},
                                {"truth", config_.truth},
                                {"rungs", o_.rungs},
                                {"offset_mm", o_.offset_mm},
                                {"force", o_.force}}},
                   {"rungs", rungs},
                   {"wall_s", SecondsSince(start)}});
    std::fputs(table.c_str(), stdout);
    return 0;
  }

 private:
  // prepare, cues, plan, train, augment, eval
  static constexpr int kStepsPerRung = 6;

  fs::path StatePath(const fs::path& rung_ws) const { return rung_ws / "ladder_rung.json"; }
  void SaveState(const fs::path& rung_ws, const json& state) const {
    WriteJsonFile(StatePath(rung_ws).string(), "ladder_rung", 1, state);
  }

  // What a rung is made from: rung o also from its offset.
  std::string RungFingerprint(char rung) const {
    return rung == 'o' ? pipeline::HashJson({{"inputs", fingerprint_}, {"offset_mm", o_.offset_mm}}) : fingerprint_;
  }

  // The rung's state file, or a fresh one; refuses a rung from other inputs.
  json OpenRung(char rung, const fs::path& rung_ws) {
    if (fs::exists(StatePath(rung_ws))) {
      json state = ReadJsonFile(StatePath(rung_ws).string(), "ladder_rung", 1);
      if (state.value("fingerprint", "") == RungFingerprint(rung)) return state;
      RELIT_REQUIRE(o_.force, rung_ws.string(), " was made from another workspace, truth or options: pass --force ",
                    "to redo it, or another --out");
    } else {
      // Never delete a folder the ladder did not make.
      RELIT_REQUIRE(!fs::exists(rung_ws), rung_ws.string(),
                    " exists and is not a ladder rung (no ladder_rung.json): pass another --out");
    }
    return {{"rung", std::string(1, rung)}, {"fingerprint", RungFingerprint(rung)}, {"done", json::array()},
            {"timings_s", json::object()}};
  }

  void Prepare(char rung, const fs::path& rung_ws, const fs::path& log) {
    LinkTree(workspace_ / "capture", rung_ws / "capture");
    LinkTree(workspace_ / "calib", rung_ws / "calib");
    if (rung == 'a') WriteTruthCalib(workspace_, truth_, rung_ws);
    if (rung == 'a' || rung == 'b' || rung == 'o') {
      const std::string mesh = rung == 'o' ? OffsetTruthMesh(synth_dir_, truth_, o_.offset_mm * 1e-3, out_)
                                           : TruthObjectMesh(synth_dir_, truth_, out_);
      RunTool({Tool("reconstruct"), "--workspace", rung_ws.string(), "--config", reconstruct_config_.string(),
               "--mesh", mesh},
              log);
    } else {
      LinkTree(workspace_ / "reconstruct", rung_ws / "reconstruct");
    }
    if (rung != 'd') spdlog::info("ladder: rung {}: {} true mattes", rung, WriteTruthMattes(rung_ws, synth_dir_, truth_));
  }

  std::string Tool(const std::string& stage) const {
    const std::string path = tools_.Find(stage);
    RELIT_REQUIRE(!path.empty(), "relit-", stage, " not found (looked in ", tools_.Searched(stage),
                  "): build relit (tools/build)");
    return path;
  }

  // Runs `step` unless the state says it is done; records its time.
  void Step(const pipeline::Step& step, const fs::path& rung_ws, json* state, const fs::path& log) {
    for (const json& done : (*state)["done"]) {
      if (done == step.name) return;
    }
    const auto start = Clock::now();
    std::vector<std::string> argv = {Tool(step.tool)};
    for (const std::string& a : step.args) argv.push_back(a == "{config}" ? relight_config_.string() : a);
    RunTool(argv, log);
    (*state)["timings_s"][step.name] = SecondsSince(start);
    (*state)["done"].push_back(step.name);
    SaveState(rung_ws, *state);
  }

  json RunRung(char rung, Progress* progress) {
    const fs::path rung_ws = out_ / (std::string("rung-") + rung);
    json state = OpenRung(rung, rung_ws);
    const fs::path log = rung_ws / "ladder.log";
    spdlog::info("ladder: rung {} ({}) in {}", rung, RungDescription(rung, o_.offset_mm), rung_ws.string());
    if (!state.value("prepared", false)) {
      // From scratch, also after a crash half-way through the preparation;
      // the state file first, so that a rerun knows the folder is a rung.
      fs::remove_all(rung_ws);
      fs::create_directories(rung_ws);
      SaveState(rung_ws, state);
      const auto start = Clock::now();
      Prepare(rung, rung_ws, log);
      state["prepared"] = true;
      state["timings_s"]["prepare"] = SecondsSince(start);
      SaveState(rung_ws, state);
    }
    progress->Advance();
    pipeline::StepGraph graph(config_, rung_ws.string(), /*with_export=*/false,
                              pipeline::WithAugment(config_, tools_));
    for (const char* kind : {"cues", "plan"}) {
      Step(*graph.Find(kind), rung_ws, &state, log);
      progress->Advance();
    }
    graph.ExpandPartitions(pipeline::ReadPlanPartitions(rung_ws.string()));
    for (const char* kind : {"train", "augment", "eval"}) {
      for (const pipeline::Step& s : graph.steps()) {
        if (s.kind == kind) Step(s, rung_ws, &state, log);
      }
      progress->Advance();
    }
    const json eval = ReadJsonFile((rung_ws / "relight" / "eval" / "eval.json").string(), "eval", 1);
    state["scores"] = RungScores(eval);
    if (rung == 'o') state["scores"]["offset_mm"] = o_.offset_mm;
    SaveState(rung_ws, state);
    return state;
  }

  const LadderOptions o_;
  const pipeline::PipelineConfig config_;
  const fs::path workspace_, out_;
  const pipeline::ToolLocator tools_;
  json truth_;
  fs::path synth_dir_, relight_config_, reconstruct_config_;
  std::string fingerprint_;
};

}  // namespace
}  // namespace relit::bench

int main(int argc, char** argv) {
  return relit::RunMain(argc, argv, [](int argc, char** argv) {
    relit::bench::LadderOptions o;
    CLI::App app{"relit-bench-relight-ladder: the relight stage on rungs of true and pipeline inputs (issue 24's "
                 "error budget)"};
    app.add_option("--pipeline", o.pipeline, "pipeline.yaml of the capture (its relight/reconstruct sections, "
                                             "inputs.truth)")->required()->check(CLI::ExistingFile);
    app.add_option("--workspace", o.workspace, "the pipeline's workspace, run up to reconstruct")
        ->required()->check(CLI::ExistingDirectory);
    app.add_option("--out", o.out, "folder for the rungs' workspaces, ladder.json and ladder.md")->required();
    app.add_option("--rungs", o.rungs, "which rungs, e.g. abcd, bd or bo")->capture_default_str();
    app.add_option("--offset-mm", o.offset_mm,
                   "rung o: the true mesh moved out along its normals by this much (negative: in)")
        ->check(CLI::Range(-10.0, 10.0))->capture_default_str();
    app.add_flag("--force", o.force, "redo rungs made from other inputs or options");
    CLI11_PARSE(app, argc, argv);
    return relit::bench::Ladder(o).Run();
  });
}
