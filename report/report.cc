#include "report/report.h"

#include <chrono>
#include <filesystem>
#include <functional>
#include <utility>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/log.h"
#include "core/options.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "core/stage_cli.h"
#include "core/stage_run.h"
#include "report/sections.h"

namespace relit::report {

namespace {

namespace fs = std::filesystem;

bool IsNotRun(const Section& section) { return section.html.rfind("<div class=\"notrun\">", 0) == 0; }

}  // namespace

ReportSummary RunReportImpl(const ReportOptions& options) {
  CheckOptions(options);
  const auto start = std::chrono::steady_clock::now();
  const fs::path workspace(options.workspace);
  RELIT_REQUIRE(fs::is_directory(workspace), "relit-report: workspace ", workspace.string(),
                " is not a folder (give the folder that holds capture/, calib/, ...)");
  StageRun run({"relit-report", workspace / "report", options.force, {}, "--workspace", "report.log",
                ParseLogLevel(options.log_level)});
  RunRecord& record = run.record();
  record.SetOptions(OptionsToJson(options));

  ReportContext context(workspace, run.path(), options);
  ReadObjectCentre(context);
  struct Builder {
    std::string id, title;  // the title is used when the section fails
    std::function<Section(ReportContext&)> build;
  };
  const std::vector<Builder> builders = {
      {"capture", "Capture", CaptureSection},
      {"calib", "Calibration", CalibSection},
      {"coverage", "View and light coverage", CoverageSection},
      {"reconstruct", "Proxy mesh, UV atlas, trimaps and mattes", ReconstructSection},
      {"training", "Training and validation per partition", TrainingSection},
      {"render", "Relit turntables", RenderSection},
      {"eval", "Evaluation against ground truth", EvalSection}};
  ReportSummary summary;
  std::vector<Section> sections;
  Progress progress("report", static_cast<int64_t>(builders.size()));
  for (const Builder& builder : builders) {
    auto timer = record.Time(builder.id);
    try {
      sections.push_back(builder.build(context));
      if (IsNotRun(sections.back())) summary.sections_not_run.push_back(builder.id);
    } catch (const std::exception& e) {
      // A broken file of one stage must not hide the rest of the report.
      const std::string message = e.what();
      sections.push_back({builder.id, builder.title, ReadError(message)});
      summary.sections_failed.push_back(builder.id);
      context.AddWarning(builder.id, "could not read the stage's files: " + message);
    }
    progress.Advance();
  }
  progress.Finish();

  std::string summary_html = "<section id=\"summary\"><h2>Summary</h2>\n";
  if (context.warnings().empty()) {
    summary_html += Paragraph("No warnings.");
  } else {
    for (const std::string& w : context.warnings()) summary_html += Warning(w);
  }
  if (!summary.sections_not_run.empty()) {
    std::string list;
    for (const std::string& id : summary.sections_not_run) list += (list.empty() ? "" : ", ") + id;
    summary_html += Paragraph("Not run yet: " + list + ".");
  }
  summary_html += "</section>\n";
  AtomicWriteFile(run.path() / "index.html",
                  Page("relit report: " + fs::absolute(workspace).lexically_normal().filename().string(),
                       summary_html, sections));
  summary.warnings = context.warnings();
  summary.seconds = SecondsSince(start);
  summary.results = context.results;
  record.Set("results", summary.results);
  record.Set("warnings", summary.warnings);
  record.Set("sections_not_run", summary.sections_not_run);
  record.Set("sections_failed", summary.sections_failed);
  spdlog::info("relit-report: wrote {} ({} warnings, not run yet: {}, unreadable: {}) in {:.1f} s",
               (workspace / "report" / "index.html").string(), summary.warnings.size(),
               summary.sections_not_run.size(), summary.sections_failed.size(), summary.seconds);
  run.Commit();
  summary.index_html = (workspace / "report" / "index.html").string();
  return summary;
}

int RunReport(int argc, char** argv) {
  CLI::App app{"relit-report: offline HTML report of a workspace (capture, calibration, coverage, proxy, "
               "training curves, turntables, evaluation). Writes W/report/index.html. See docs/report.md."};
  StageCommandLine cli("report", "writes W/report");
  cli.AddWorkspaceAndConfig(app);
  cli.AddLogLevelAndForce(app);
  CLI11_PARSE(app, argc, argv);
  return cli.RunStage(cli.ReadOptions<ReportOptions>(), RunReportImpl);
}

}  // namespace relit::report
