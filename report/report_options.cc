#include "report/report_options.h"

#include "core/error.h"
#include "core/log.h"
#include "core/options.h"

namespace relit::report {

void MeshPreviewOptions::Read(OptionsReader& reader) {
  reader.ReadRange("size_px", &size_px, 32, 2048);
  reader.ReadRange("views", &views, 0, 12);
  reader.ReadRange("elevation_deg", &elevation_deg, -10.0, 90.0);
  reader.ReadRange("samples_per_pixel", &samples_per_pixel, 1, 1024);
  reader.Finish();
}

void MeshPreviewOptions::Check() const {
  RELIT_REQUIRE(size_px >= 32 && size_px <= 2048, "report mesh_preview.size_px must be in [32, 2048]");
  RELIT_REQUIRE(views >= 0 && views <= 12, "report mesh_preview.views must be in [0, 12]");
  RELIT_REQUIRE(samples_per_pixel >= 1, "report mesh_preview.samples_per_pixel must be at least 1");
  RELIT_REQUIRE(elevation_deg >= -10 && elevation_deg <= 90, "report mesh_preview.elevation_deg must be in [-10, 90]");
}

nlohmann::json MeshPreviewOptions::ToJson() const {
  return {{"size_px", size_px}, {"views", views}, {"elevation_deg", elevation_deg},
          {"samples_per_pixel", samples_per_pixel}};
}

void ReportOptions::Read(OptionsReader& reader) {
  reader.Read("workspace", &workspace);
  reader.Read("log_level", &log_level);
  reader.ReadRange("thumbnail_width_px", &thumbnail_width_px, 32, 2048);
  reader.ReadRange("sample_frames", &sample_frames, 0, 64);
  reader.ReadRange("strip_frames", &strip_frames, 0, 64);
  OptionsReader preview = reader.Child("mesh_preview");
  mesh_preview.Read(preview);
  OptionsReader thresholds = reader.Child("coverage");
  coverage.Read(thresholds);
  reader.Finish();
}

void ReportOptions::Check() const {
  RELIT_REQUIRE(!workspace.empty(), "relit-report: no workspace given (--workspace W)");
  ParseLogLevel(log_level);
  RELIT_REQUIRE(thumbnail_width_px >= 32 && thumbnail_width_px <= 2048,
                "report thumbnail_width_px must be in [32, 2048]");
  RELIT_REQUIRE(sample_frames >= 0 && strip_frames >= 0, "report sample_frames/strip_frames must not be negative");
  mesh_preview.Check();
  coverage.Check();
}

nlohmann::json ReportOptions::ToJson() const {
  return {{"workspace", workspace},
          {"log_level", log_level},
          {"thumbnail_width_px", thumbnail_width_px},
          {"sample_frames", sample_frames},
          {"strip_frames", strip_frames},
          {"mesh_preview", mesh_preview.ToJson()},
          {"coverage", coverage.ToJson()}};
}

}  // namespace relit::report
