// The sections of the report, one function per stage. Each reads that
// stage's files from the workspace; when they are missing the section says
// "not run yet", when they cannot be read it shows the error. Neither stops
// the report.
#pragma once

#include "report/html.h"
#include "report/report_context.h"

namespace relit::report {

Section CaptureSection(ReportContext& context);      // W/capture/capture.json
Section CalibSection(ReportContext& context);        // W/calib/{cameras,lights,calib_report}.json
Section CoverageSection(ReportContext& context);     // calib + reconstruct/proxy.json + relight/plan
Section ReconstructSection(ReportContext& context);  // W/reconstruct/
Section TrainingSection(ReportContext& context);     // W/relight/plan, W/relight/partitions/KK
Section RenderSection(ReportContext& context);       // W/relight/render
Section EvalSection(ReportContext& context);         // W/relight/eval

// Reads W/reconstruct/proxy.json (if any) into the context's object centre.
void ReadObjectCentre(ReportContext& context);

}  // namespace relit::report
