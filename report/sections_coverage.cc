// View/light coverage of the hemisphere with the partition layout.
#include <cmath>

#include "core/json_file.h"
#include "core/workspace.h"
#include "relight/partitions.h"
#include "report/coverage.h"
#include "report/sections.h"
#include "report/svg_plot.h"

namespace relit::report {

namespace {

using nlohmann::json;
constexpr double kDeg = 180.0 / 3.14159265358979323846;

struct Layout {
  std::string source;
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;
  std::vector<int> train_frames, validation_frames;  // per partition; empty when unknown
};

Layout ReadLayout(ReportContext& context, const std::vector<Eigen::Vector3d>& view_directions) {
  Layout layout;
  const std::string plan_file = "relight/plan/plan.json";
  if (context.Has(plan_file)) {
    const json plan = ReadJsonFile(context.Input(plan_file).string(), "relight_plan", 1);
    const json& l = JsonField(plan, "layout", plan_file);
    for (const json& v : JsonField(l, "vertices", plan_file + ": layout")) {
      layout.vertices.push_back(Vector3FromJson(v, plan_file + ": layout.vertices"));
    }
    for (const json& t : l.value("triangles", json::array())) layout.triangles.push_back(t.get<std::array<int, 3>>());
    for (const json& p : JsonField(plan, "partitions", plan_file)) {
      layout.train_frames.push_back(static_cast<int>(p.value("train_frames", json::array()).size()));
      layout.validation_frames.push_back(static_cast<int>(p.value("validation_frames", json::array()).size()));
    }
    layout.source = "the layout of W/relight/plan/plan.json";
    return layout;
  }
  // No plan yet: the default DNL layout, with this capture's frames assigned to it.
  const relight::PartitionLayout dnl = relight::PartitionLayout::Dnl13();
  layout.vertices = dnl.vertices();
  layout.triangles = dnl.triangles();
  layout.train_frames.assign(layout.vertices.size(), 0);
  if (!view_directions.empty()) {
    const auto assigned = dnl.AssignFrames(view_directions);
    for (size_t k = 0; k < assigned.size(); ++k) layout.train_frames[k] = static_cast<int>(assigned[k].size());
  }
  layout.source = "the default dnl13 layout (no relight plan yet); frame counts are this capture's frames "
                  "assigned to it";
  return layout;
}

}  // namespace

Section CoverageSection(ReportContext& context) {
  Section section{"coverage", "View and light coverage", ""};
  if (!context.Has("calib/cameras.json") || !context.Has("calib/lights.json")) {
    return NotRunSection(section, "W/calib/cameras.json or lights.json", "Run relit-calib --workspace W.");
  }
  std::string& html = section.html;
  const CamerasFile cameras = ReadCamerasFile(context.Input("calib/cameras.json").string());
  const LightsFile lights = ReadLightsFile(context.Input("calib/lights.json").string());
  const Eigen::Vector3d centre = context.object_centre_m;
  std::vector<Eigen::Vector3d> views, light_dirs, relative;
  for (const FrameLight& l : lights.frames) {
    const CalibratedFrame* frame = cameras.Find(l.view_frame);
    if (frame == nullptr) continue;
    const Eigen::Vector3d v = frame->cam_from_world.Inverse().translation - centre;
    const Eigen::Vector3d d = l.position_m - centre;
    if (v.norm() <= 0 || d.norm() <= 0) continue;
    views.push_back(v);
    light_dirs.push_back(d);
    relative.push_back(LightInViewFrame(v, d));
  }
  const CoverageStats stats = ComputeCoverage(views, light_dirs, context.options().coverage);
  context.results["coverage"] = stats.ToJson();
  context.results["coverage"]["object_centre_m"] = ToJson(centre);
  const CoverageThresholds& t = context.options().coverage;
  html += Paragraph("Directions from the object centre (" + context.object_centre_source + ": " +
                    Fixed(centre.x(), 3) + ", " + Fixed(centre.y(), 3) + ", " + Fixed(centre.z(), 3) +
                    " m) to the camera and to the flash, for the " + std::to_string(stats.frames) +
                    " phone V frames with a light position. Rule: docs/report.md.");
  for (const std::string& w : stats.warnings) {
    html += Warning(w);
    context.AddWarning("coverage", w);
  }
  auto row = [](const std::string& name, double value, double limit, const std::string& relation) {
    return std::vector<std::string>{name, Fixed(value, 1) + "°", relation + " " + Fixed(limit, 1) + "°",
                                    (relation == "≥" ? value >= limit : value <= limit) ? "ok" : "POOR"};
  };
  html += Table({"statistic", "value", "wanted", ""},
                {row("camera direction spread", stats.view_spread_deg, t.min_view_spread_deg, "≥"),
                 row("light direction spread", stats.light_spread_deg, t.min_light_spread_deg, "≥"),
                 row("median camera–light angle", stats.median_view_light_angle_deg, t.min_view_light_angle_deg, "≥"),
                 row("light spread seen from the camera", stats.relative_light_spread_deg,
                     t.min_relative_light_spread_deg, "≥")});
  html += Paragraph("Hemisphere cells (8 azimuth × 3 elevation bands = 24): " + std::to_string(stats.view_cells) +
                    " seen by the camera, " + std::to_string(stats.light_cells) + " lit by the flash, " +
                    std::to_string(stats.view_light_cell_pairs) + " distinct (camera cell, light cell) pairs.");

  const Layout layout = ReadLayout(context, views);
  HemisphereOptions hemisphere;
  hemisphere.title = "Camera and light directions (upper hemisphere from above)";
  hemisphere.layout_vertices = layout.vertices;
  hemisphere.layout_triangles = layout.triangles;
  hemisphere.link_first_two_series = true;
  HemisphereOptions seen;
  seen.title = "Light direction seen from the camera";
  seen.size_px = 320;
  html += FigureRow(
      {Figure(context.WriteAsset("coverage_hemisphere.svg",
                                 HemisphereSvg(hemisphere, {{"camera", views, "#1f77b4", 3},
                                                            {"flash", light_dirs, "#ff7f0e", 3}})),
              "Azimuthal equal-area projection (+X right, +Y up, rings at 0/30/60° elevation). Grey lines join "
              "the camera and the flash of the same frame; dashed: view partitions (" + layout.source + ")."),
       Figure(context.WriteAsset("coverage_relative.svg",
                                 HemisphereSvg(seen, {{"flash relative to camera", relative, "#9467bd", 3}})),
              "The flash in a frame attached to the camera direction (centre = the camera's own direction, up = "
              "world up side). A tight cluster means the light travels with the camera.")});
  // Partition table.
  std::vector<std::vector<std::string>> rows;
  int empty = 0;
  for (size_t k = 0; k < layout.vertices.size(); ++k) {
    const Eigen::Vector3d d = layout.vertices[k].normalized();
    const int train = k < layout.train_frames.size() ? layout.train_frames[k] : 0;
    empty += train == 0;
    rows.push_back({std::to_string(k), Fixed(std::asin(std::clamp(d.z(), -1.0, 1.0)) * kDeg, 0) + "°",
                    Fixed(std::atan2(d.y(), d.x()) * kDeg, 0) + "°", std::to_string(train),
                    k < layout.validation_frames.size() ? std::to_string(layout.validation_frames[k]) : "–"});
  }
  html += "<h3>View partitions</h3>\n" +
          Table({"partition", "elevation", "azimuth", "training frames", "validation frames"}, rows);
  if (empty > 0 && !layout.vertices.empty()) {
    const std::string w = std::to_string(empty) + " of " + std::to_string(layout.vertices.size()) +
                          " view partitions have no training frame: views there are extrapolated";
    html += Warning(w);
    context.AddWarning("coverage", w);
  }
  return section;
}

}  // namespace relit::report
