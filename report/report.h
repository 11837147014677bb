// relit-report: an offline HTML report of a workspace. Reads whatever the
// stages have written so far (capture, calib, reconstruct, relight plan /
// training / render / eval) and writes W/report/ atomically: index.html,
// assets/ (SVG plots made here, PNG thumbnails, proxy mesh previews rendered
// with the project's path tracer), report.log and run.json. Sections of
// stages that have not run say so. See docs/report.md.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "report/report_options.h"

namespace relit::report {

struct ReportSummary {
  std::string index_html;              // W/report/index.html
  std::vector<std::string> warnings;   // the summary warnings shown at the top
  std::vector<std::string> sections_not_run;  // ids of sections whose stage has not run
  std::vector<std::string> sections_failed;   // ids of sections whose files could not be read
  nlohmann::json results;              // figures of the sections, e.g. results["coverage"]
  double seconds = 0;
};

ReportSummary RunReportImpl(const ReportOptions& options);

// relit-report --workspace W [--config report.yaml] [--log-level L]
int RunReport(int argc, char** argv);

}  // namespace relit::report
