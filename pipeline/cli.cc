#include "pipeline/cli.h"

#include <filesystem>
#include <iostream>

#include <CLI/CLI.hpp>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/log.h"
#include "pipeline/config.h"
#include "pipeline/runner.h"

namespace relit::pipeline {

namespace fs = std::filesystem;

int RunRelit(int argc, char** argv) {
  CLI::App app{"relit: runs the capture-to-relight pipeline described by a pipeline.yaml in a "
               "workspace folder, rerunning only the steps whose inputs, parameters or tools "
               "changed. See docs/pipeline.md."};
  app.require_subcommand(1);
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace | debug | info | warn | error");

  std::string init_path = "pipeline.yaml";
  bool init_force = false;
  CLI::App* init = app.add_subcommand("init", "write a commented pipeline.yaml template for a new capture");
  init->add_option("file", init_path, "where to write it (default pipeline.yaml)");
  init->add_flag("--force", init_force, "replace an existing file");

  std::string pipeline = "pipeline.yaml";
  RunOptions options;
  CLI::App* run = app.add_subcommand("run", "run every step that is not up to date");
  run->add_option("pipeline", pipeline, "pipeline file (default pipeline.yaml)");
  run->add_option("--workspace,-w", options.workspace, "workspace folder W (created if missing)")
      ->required();
  run->add_option("--only", options.only,
                  "run only this step (if stale); a name (calib, train-03) or group (train, relight)");
  run->add_option("--from", options.from, "rerun this step and everything downstream of it");
  run->add_option("--to", options.to, "stop after this step (and the steps it needs)");
  run->add_option("--force", options.force, "run this step even if it is up to date");
  run->add_flag("--dry-run,-n", options.dry_run, "print what would run and why, run nothing");
  run->add_option("--jobs,-j", options.jobs, "local steps at once (default: run.jobs)")
      ->check(CLI::Range(1, 1024));

  std::string status_pipeline = "pipeline.yaml", status_workspace;
  CLI::App* status = app.add_subcommand("status", "show each step: up to date, stale (and why), running, failed");
  status->add_option("pipeline", status_pipeline, "pipeline file (default pipeline.yaml)");
  status->add_option("--workspace,-w", status_workspace, "workspace folder W")->required();

  // `relit run --log-level L` (docs/pipeline.md) as well as `relit --log-level L run`.
  for (CLI::App* sub : {run, status}) sub->add_option("--log-level", log_level, "trace | debug | info | warn | error");
  CLI11_PARSE(app, argc, argv);
  SetVerbosity(ParseLogLevel(log_level));

  if (init->parsed()) {
    std::error_code error;
    RELIT_REQUIRE(init_force || !fs::exists(init_path, error), init_path,
                  " already exists; pass --force to replace it");
    AtomicWriteFile(init_path, PipelineTemplate());
    std::cout << "wrote " << init_path
              << ": set inputs and board, then run: relit run " << init_path << " --workspace W\n";
    return 0;
  }
  if (run->parsed()) {
    const PipelineConfig config = PipelineConfig::Load(pipeline);
    return RunPipeline(config, options, std::cout, &std::cerr);
  }
  const PipelineConfig config = PipelineConfig::Load(status_pipeline);
  std::error_code error;
  RELIT_REQUIRE(!fs::exists(status_workspace, error) || fs::is_directory(status_workspace, error),
                "--workspace ", status_workspace, " is a file, not a workspace folder: give the folder relit run "
                "wrote");
  RELIT_REQUIRE(fs::is_directory(status_workspace, error), "workspace ", status_workspace,
                " does not exist; relit run creates it");
  std::cout << "pipeline " << config.file << ", workspace "
            << fs::absolute(status_workspace).lexically_normal().string() << "\n";
  PrintStatus(PipelineStatus(config, status_workspace), std::cout);
  return 0;
}

}  // namespace relit::pipeline
