// relit-bench-cycles-capture: an independent renderer in the loop (issue 25
// item 3). Renders a dual-phone capture with Blender Cycles (cached), runs
// the whole pipeline on it with `relit run`, and scores every stage against
// Blender's ground truth. `--renderer relit` makes the same capture (same
// options, plan and pipeline) with relit-synth instead, for the row to
// compare with. See docs/benchmarks.md, "Independent renderer (Cycles)".
//
//   relit-bench-cycles-capture --out bench-out/cycles
//   relit-bench-cycles-capture --out bench-out/cycles-relit --renderer relit
//   relit-bench-cycles-capture --out bench-out/cycles --compare-with bench-out/cycles-relit --skip-pipeline
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <thread>

#include <CLI/CLI.hpp>

#include "bench/bench_util.h"
#include "bench/capture_scores.h"
#include "bench/cycles_capture.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/log.h"
#include "core/main_wrapper.h"
#include "core/options.h"
#include "core/shell.h"
#include "tools/synth/synth.h"
#include "tools/synth/truth.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace relit::bench {
namespace {

// relit-synth's capture of the same options (preset bunny, no sphere: the
// painted sphere is Blender's), rebuilt only when the options change.
bool MakeRelitCapture(synth::SynthOptions options, const fs::path& out) {
  options.out = (out / "capture").string();
  json stored = OptionsToJson(options);
  stored.erase("out");
  const fs::path truth_path = out / "capture" / "truth.json";
  const fs::path options_path = out / "capture_options.json";
  if (fs::exists(truth_path) && fs::exists(options_path)) {
    std::ifstream in(options_path);
    if (json::parse(in, nullptr, false) == stored) {
      spdlog::info("relit-synth capture {} is up to date", options.out);
      return true;
    }
  }
  synth::RunSynthImpl(options);
  std::ofstream(options_path) << stored.dump(2);
  return false;
}

int Run(int argc, char** argv) {
  CLI::App app{"relit-bench-cycles-capture: render a dual-phone capture with Blender Cycles (cached), run the "
               "whole pipeline on it and score sync, camera ATE, proxy Chamfer and eval PSNR against Blender's "
               "ground truth. See docs/benchmarks.md."};
  std::string out, renderer = "cycles", blender = "blender", compare_with, log_level = "info";
  std::string config = std::string(RELIT_BENCH_SOURCE_DIR) + "/configs/cycles-capture.yaml";
  std::string pipeline = std::string(RELIT_BENCH_SOURCE_DIR) + "/configs/pipeline-cycles.yaml";
  std::string relit = std::string(RELIT_BUILD_DIR) + "/pipeline/relit";
  int frames = 0, spp = 0, eval_spp = 0, threads = 2;
  bool render_only = false, skip_pipeline = false;
  app.add_option("--out", out, "output folder: render/ (cache), capture/, workspace/, scores.json, bench.json")
      ->required();
  app.add_option("--config", config, "SynthOptions YAML: size, lenses, board, paths, audio (default "
                                     "bench/configs/cycles-capture.yaml)")->check(CLI::ExistingFile);
  app.add_option("--pipeline", pipeline, "pipeline.yaml template; its inputs are relative to --out "
                                         "(default bench/configs/pipeline-cycles.yaml)")->check(CLI::ExistingFile);
  app.add_option("--renderer", renderer, "cycles (Blender) | relit (relit-synth, the row to compare with)")
      ->check(CLI::IsMember({"cycles", "relit"}));
  app.add_option("--frames", frames, "phone V frames (phone L films 10% more); 0 = the config's")
      ->check(CLI::Range(0, 2000));
  app.add_option("--spp", spp, "video samples per pixel; 0 = the config's")->check(CLI::Range(0, 4096));
  app.add_option("--eval-spp", eval_spp, "eval samples per pixel; 0 = the config's")->check(CLI::Range(0, 4096));
  app.add_option("--threads", threads, "Cycles CPU threads")->check(CLI::Range(1, 256));
  app.add_option("--blender", blender, "Blender executable");
  app.add_option("--relit", relit, "the relit orchestrator");
  app.add_flag("--render-only", render_only, "stop after the capture");
  app.add_flag("--skip-pipeline", skip_pipeline, "score the existing workspace without running relit");
  app.add_option("--compare-with", compare_with, "another output folder of this tool: print its scores beside");
  app.add_option("--log-level", log_level, "trace | debug | info | warn | error");
  CLI11_PARSE(app, argc, argv);
  SetVerbosity(ParseLogLevel(log_level));

  synth::SynthOptions options = synth::SynthOptions::FromFile(config, "", "demo");
  if (frames > 0) {
    options.frames_per_video = frames;
    options.light_frames_per_video = (frames * 11 + 5) / 10;
  }
  if (spp > 0) options.samples_per_pixel = spp;
  if (eval_spp > 0) options.eval_samples_per_pixel = eval_spp;
  const fs::path root = fs::absolute(out);
  options.out = (root / "capture").string();
  CheckOptions(options);

  fs::create_directories(root);
  json previous;  // a --skip-pipeline run keeps the pipeline's time of the run that ran it
  if (fs::exists(root / "bench.json")) previous = ReadJsonFile((root / "bench.json").string(), "bench_cycles_capture", 1);
  json record = {{"tool", "relit-bench-cycles-capture"}, {"renderer", renderer}, {"date", Today()},
                 {"config", fs::absolute(config).string()}, {"pipeline", fs::absolute(pipeline).string()},
                 {"synth_options", OptionsToJson(options)}, {"load_average_start", LoadAverage()},
                 {"nproc", std::thread::hardware_concurrency()}};
  const auto start = std::chrono::steady_clock::now();
  if (renderer == "cycles") {
    CyclesCaptureOptions cycles;
    cycles.synth = options;
    cycles.out_dir = root.string();
    cycles.blender = blender;
    cycles.script = std::string(RELIT_BENCH_SOURCE_DIR) + "/cycles_capture.py";
    cycles.threads = threads;
    const CyclesCaptureSummary summary = MakeCyclesCapture(cycles);
    record["capture"] = summary.ToJson();
  } else {
    const auto render_start = std::chrono::steady_clock::now();
    const bool reused = MakeRelitCapture(options, root);
    record["capture"] = {{"capture_dir", (root / "capture").string()}, {"capture_reused", reused},
                         {"render_s", reused ? 0.0 : SecondsSince(render_start)}};
  }
  record["capture_s"] = SecondsSince(start);
  if (render_only) {
    WriteJsonFile((root / "bench.json").string(), "bench_cycles_capture", 1, record);
    return 0;
  }

  if (!skip_pipeline) {
    // The template's inputs (capture/view.mp4, ...) resolve against its folder: copy it next to capture/.
    const fs::path config_copy = root / "pipeline.yaml";
    fs::copy_file(pipeline, config_copy, fs::copy_options::overwrite_existing);
    const std::string command = ShellQuote(relit) + " run " + ShellQuote(config_copy.string()) + " --workspace " +
                                ShellQuote((root / "workspace").string());
    spdlog::info("pipeline: {}", command);
    const auto pipeline_start = std::chrono::steady_clock::now();
    const int status = std::system(command.c_str());
    record["pipeline_s"] = SecondsSince(pipeline_start);
    RELIT_REQUIRE(status == 0, "the pipeline failed (", ExitDescription(status), "): ", command);
  } else if (previous.contains("pipeline_s")) {
    record["pipeline_s"] = previous["pipeline_s"];
  }
  const CaptureScores scores = ScoreCapture((root / "workspace").string(), (root / "capture").string());
  WriteJsonFile((root / "scores.json").string(), "capture_scores", 1, scores.ToJson());
  record["scores"] = scores.ToJson();
  record["load_average_end"] = LoadAverage();
  record["total_s"] = SecondsSince(start);
  WriteJsonFile((root / "bench.json").string(), "bench_cycles_capture", 1, record);

  std::vector<std::pair<std::string, CaptureScores>> rows;
  if (!compare_with.empty()) {
    // The other folder's scores, recomputed from its files (same code, same truth reader).
    rows.push_back({fs::path(compare_with).filename().string(),
                    ScoreCapture((fs::path(compare_with) / "workspace").string(),
                                 (fs::path(compare_with) / "capture").string())});
  }
  rows.push_back({root.filename().string() + " (" + renderer + ")", scores});
  std::cout << ScoresTable(rows);
  std::cout << "capture " << record["capture_s"].get<double>() << " s, total " << record["total_s"].get<double>()
            << " s, load " << LoadAverage() << "; " << (root / "bench.json").string() << "\n";
  return 0;
}

}  // namespace
}  // namespace relit::bench

int main(int argc, char** argv) { return relit::RunMain(argc, argv, relit::bench::Run); }
