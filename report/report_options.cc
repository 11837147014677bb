#include "report/report_options.h"

#include "core/error.h"
#include "core/log.h"

namespace relit::report {

RELIT_OPTION_FIELDS(MeshPreviewOptions,
    .Add("size_px", &S::size_px, 32, 2048, "square previews of the proxy mesh")
    .Add("views", &S::views, 0, 12, "azimuths spread evenly around the object")
    .Add("elevation_deg", &S::elevation_deg, -10.0, 90.0, "above the board plane")
    .Add("samples_per_pixel", &S::samples_per_pixel, 1, 1024, "path tracer samples (direct light only)"))

RELIT_OPTION_FIELDS(ReportOptions,
    .Add("workspace", &S::workspace, "W: reads the stages' folders, writes W/report (`--workspace`)")
    .Add("log_level", &S::log_level, LogLevelNames(), "what the report prints (`--log-level`)")
    .Add("thumbnail_width_px", &S::thumbnail_width_px, 32, 2048,
         "frames, trimaps, mattes (turntable strips: 2/3 of it)")
    .Add("sample_frames", &S::sample_frames, 0, 64, "frames shown with their trimap and matte")
    .Add("strip_frames", &S::strip_frames, 0, 64, "frames per turntable strip")
    .Section("mesh_preview", &S::mesh_preview)
    .Section("coverage", &S::coverage))

void ReportOptions::Check() const {
  RELIT_REQUIRE(!workspace.empty(), "relit-report: no workspace given (--workspace W)");
}

}  // namespace relit::report
