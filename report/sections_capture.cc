// Capture and calibration sections.
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/capture_file.h"
#include "core/json_file.h"
#include "core/workspace.h"
#include "report/sections.h"
#include "report/svg_plot.h"

namespace relit::report {

namespace {

using nlohmann::json;

const std::map<std::string, std::string>& ReasonMeaning() {
  static const std::map<std::string, std::string> meaning = {
      {"kept", "used by the later stages"},
      {"duplicate", "same picture as the previous frame (frame repeated by the encoder)"},
      {"dark", "nearly black"},
      {"clipped", "too much of the frame saturated"},
      {"blurred", "motion blur: much less sharp than its neighbours"},
      {"outside_light_video", "no phone L frame on both sides (outside the light video)"},
      {"not_selected", "thinned out to the target frame count / rate"}};
  return meaning;
}

// A frame count, or "–" where the file has none.
std::string CountText(const std::optional<int>& count) {
  return count ? std::to_string(*count) : JsonScalarText(json());
}

std::string SyncHtml(ReportContext& context, const json& sync) {
  std::string html = "<h3>Audio synchronisation</h3>\n";
  const std::string method = sync.value("method", "?");
  std::vector<std::vector<std::string>> rows = {
      {"method", method},
      {"offset (t_view = t_light + offset)", Fixed(sync.value("offset_s", NAN) * 1e3, 2) + " ms"}};
  if (method != "gcc-phat") {
    rows.push_back({"confidence", "– (offset given by hand)"});
    return html + Table({"", ""}, rows);
  }
  const double confidence = sync.value("confidence", NAN);
  const double min_confidence = sync.value("min_confidence", NAN);
  rows.push_back({"confidence (main peak / best other peak)", Fixed(confidence, 2) + " (minimum " +
                                                                   Fixed(min_confidence, 2) + ")"});
  rows.push_back({"main peak", Fixed(sync.value("peak", NAN), 4)});
  rows.push_back({"second peak", Fixed(sync.value("second_peak", NAN), 4) + " at " +
                                     Fixed(sync.value("second_peak_offset_s", NAN) * 1e3, 2) + " ms"});
  rows.push_back({"search window", "±" + Fixed(sync.value("search_window_s", NAN), 2) + " s at " +
                                       JsonScalarText(sync.value("sample_rate_hz", json())) + " Hz"});
  html += Table({"", ""}, rows);
  if (std::isfinite(confidence) && std::isfinite(min_confidence) && confidence < 1.5 * min_confidence) {
    html += Warning("the audio offset is only just above the confidence limit: check it (clap at the start)");
    context.AddWarning("capture", "low audio sync confidence " + Fixed(confidence, 2));
  }
  // relit-capture stores the two strongest peaks of the GCC-PHAT correlation,
  // not the whole curve: show those on the search window.
  PlotOptions plot;
  plot.title = "GCC-PHAT correlation peaks";
  plot.x_label = "offset (s)";
  plot.y_label = "correlation";
  plot.height_px = 220;
  const double window = sync.value("search_window_s", NAN);
  if (std::isfinite(window)) {
    plot.x_min = -window;
    plot.x_max = window;
  }
  plot.y_min = 0;
  PlotSeries main_peak{"main peak (offset)", {sync.value("offset_s", NAN)}, {sync.value("peak", NAN)}, "#d62728",
                       false, true, 4, true};
  PlotSeries second{"second peak", {sync.value("second_peak_offset_s", NAN)}, {sync.value("second_peak", NAN)},
                    "#7f7f7f", false, true, 4, true};
  html += FigureRow({Figure(context.WriteAsset("sync_peaks.svg", PlotSvg(plot, {main_peak, second})),
                            "The two peaks capture.json stores (relit-capture does not keep the whole "
                            "correlation curve).")});
  return html;
}

}  // namespace

Section CaptureSection(ReportContext& context) {
  Section section{"capture", "Capture", ""};
  const std::string file = "capture/capture.json";
  if (!context.Has(file)) {
    return NotRunSection(section, "W/" + file, "Run relit-capture --view V.mp4 --light L.mp4 --out W/capture.");
  }
  const CaptureFile capture = ReadCaptureFile(context.Input(file).string());
  std::string& html = section.html;
  // Kept / rejected frames by reason.
  const std::map<std::string, int>& view_counts = capture.view_counts;
  int decoded = 0;
  for (const auto& [reason, n] : view_counts) decoded += n;
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> order = {"kept"};
  for (const auto& [reason, n] : view_counts) {
    if (reason != "kept") order.push_back(reason);
  }
  for (const std::string& reason : order) {
    if (!view_counts.count(reason)) continue;
    const int n = view_counts.at(reason);
    const auto meaning = ReasonMeaning().find(reason);
    rows.push_back({reason, std::to_string(n), Fixed(decoded > 0 ? 100.0 * n / decoded : 0, 1) + " %",
                    meaning == ReasonMeaning().end() ? "" : meaning->second});
  }
  html += "<h3>Phone V frames</h3>\n";
  html += Paragraph(std::to_string(decoded) + " frames decoded from phone V; phone L: " +
                    CountText(capture.light_usable) + " usable, " + CountText(capture.light_kept) +
                    " kept around the kept V frames.");
  html += Table({"frames", "count", "share", "why"}, rows);
  const size_t geometry_frames = capture.geometry.size();
  if (geometry_frames > 0) {
    html += Paragraph("Geometry pass: " + std::to_string(geometry_frames) +
                      " frames kept (ambient light; the proxy mesh is built from them).");
  }
  const int kept = view_counts.count("kept") ? view_counts.at("kept") : 0;
  if (kept < 10) {
    html += Warning("only " + std::to_string(kept) + " phone V frames kept: too few to train on");
    context.AddWarning("capture", "only " + std::to_string(kept) + " phone V frames kept");
  }
  // Sharpness over time, kept and rejected by reason.
  std::map<std::string, PlotSeries> by_reason;
  auto add = [&](const std::string& reason, double time_s, double sharpness) {
    PlotSeries& s = by_reason[reason];
    s.label = reason;
    s.line = false;
    s.markers = true;
    s.x.push_back(time_s);
    s.y.push_back(sharpness);
  };
  for (const CaptureFrame& f : capture.view) add("kept", f.time_s, f.sharpness);
  for (const RejectedFrame& f : capture.rejected_view) add(f.reason, f.time_s, f.sharpness);
  std::vector<PlotSeries> series;
  if (by_reason.count("kept")) series.push_back(by_reason["kept"]);
  for (auto& [reason, s] : by_reason) {
    if (reason != "kept") series.push_back(s);
  }
  PlotOptions plot{"Phone V frames: sharpness over time", "time on the common clock (s)",
                   "sharpness (variance of Laplacian)"};
  plot.log_y = true;
  html += FigureRow({Figure(context.WriteAsset("capture_frames.svg", PlotSvg(plot, series)),
                            "Every decoded phone V frame; colour = kept or the reason it was rejected.")});
  html += SyncHtml(context, capture.sync.is_object() ? capture.sync : json::object());
  return section;
}

Section CalibSection(ReportContext& context) {
  Section section{"calib", "Calibration", ""};
  if (!context.Has("calib/cameras.json")) {
    return NotRunSection(section, "W/calib/cameras.json", "Run relit-calib --workspace W.");
  }
  std::string& html = section.html;
  const CamerasFile cameras = ReadCamerasFile(context.Input("calib/cameras.json").string());
  // Residuals and registration (calib_report.json).
  if (context.Has("calib/calib_report.json")) {
    const json report = ReadJsonFile(context.Input("calib/calib_report.json").string(), "calib_report", 1);
    html += "<h3>Residuals and registration</h3>\n";
    std::vector<std::vector<std::string>> rows;
    const std::vector<std::pair<std::string, std::string>> device_names = {
        {"view", "phone V (camera)"}, {"light", "phone L (flash)"}, {"geometry", "geometry pass (phone V)"}};
    for (const auto& [device, name] : device_names) {
      if (!report["registered"].contains(device)) continue;  // no geometry pass
      const json detection = report["detection"].value(device, json::object());
      const json board_rms = report["refine_board_only"].value("corner_rms_px_by_device", json::object());
      const json joint_rms = report["refine"].value("corner_rms_px_by_device", json::object());
      rows.push_back({name,
                      JsonScalarText(report["registered"].value(device, json())) + " / " +
                          JsonScalarText(report["registered"].value(device + "_frames", json())),
                      JsonScalarText(detection.value("frames_with_board", json())),
                      JsonScalarText(detection.value("mean_corners", json())),
                      Fixed(board_rms.value(device, NAN), 3), Fixed(joint_rms.value(device, NAN), 3)});
    }
    html += Table({"device", "registered / frames", "frames with board", "corners per frame",
                   "corner RMS board only (px)", "corner RMS final (px)"},
                  rows);
    const json sfm = report.value("sfm", json::object());
    html += Paragraph(sfm.value("ran", true) ? "Structure from motion: " + JsonScalarText(sfm.value("registered", json())) +
                                                   " images registered; SfM point RMS " +
                                                   Fixed(report["refine"].value("point_rms_px", NAN), 3) + " px."
                                             : "Structure from motion was not run (--no-sfm): poses come from the "
                                               "board alone.");
    const json lights = report.value("lights", json::object());
    const size_t unreliable = lights.value("unreliable", json::array()).size();
    html += Paragraph("Lights: " + JsonScalarText(lights.value("frames", json())) + " phone V frames lit, largest gap "
                      "to a registered phone L frame " + Fixed(lights.value("max_gap_s", NAN) * 1e3, 1) + " ms, " +
                      std::to_string(unreliable) + " unreliable.");
    if (unreliable > 0) {
      context.AddWarning("calib", std::to_string(unreliable) + " light positions are unreliable (gaps in phone L)");
    }
    html += Paragraph("calib_report.json keeps RMS residuals per device, not per frame.");
    html += "<details><summary>Board scale check</summary>" + ScalarTable(report.value("scale_check", json::object())) +
            "</details>\n";
  } else {
    html += NotRunYet("W/calib/calib_report.json", "Rerun relit-calib.");
  }
  // Lenses.
  std::vector<std::vector<std::string>> lens_rows;
  for (const auto& [device, in] : cameras.devices) {
    lens_rows.push_back({device, std::to_string(in.width) + "×" + std::to_string(in.height), Fixed(in.fx, 1),
                         Fixed(in.fy, 1), Fixed(in.cx, 1), Fixed(in.cy, 1), Fixed(in.distortion.k1, 4),
                         Fixed(in.distortion.k2, 4)});
  }
  html += "<h3>Lenses</h3>\n" + Table({"device", "size", "fx", "fy", "cx", "cy", "k1", "k2"}, lens_rows);

  // Trajectories: top view and height over time.
  PlotSeries view_top{"phone V", {}, {}, "#1f77b4", true, true, 2.5}, light_top{"phone L", {}, {}, "#7f7f7f", true, true, 2};
  PlotSeries flash_top{"flash", {}, {}, "#ff7f0e", false, true, 2.5};
  // Geometry-pass frames run on their own clock: top view only.
  PlotSeries geometry_top{"geometry pass", {}, {}, "#2ca02c", false, true, 2.5};
  PlotSeries view_z = view_top, light_z = light_top, flash_z = flash_top;
  for (const CalibratedFrame& f : cameras.frames) {
    const Eigen::Vector3d c = f.cam_from_world.Inverse().translation;
    if (f.device == "geometry") {
      geometry_top.x.push_back(c.x());
      geometry_top.y.push_back(c.y());
      continue;
    }
    PlotSeries& top = f.device == "view" ? view_top : light_top;
    PlotSeries& z = f.device == "view" ? view_z : light_z;
    top.x.push_back(c.x());
    top.y.push_back(c.y());
    z.x.push_back(f.time_s);
    z.y.push_back(c.z());
  }
  if (context.Has("calib/lights.json")) {
    const LightsFile lights = ReadLightsFile(context.Input("calib/lights.json").string());
    for (const FrameLight& l : lights.frames) {
      flash_top.x.push_back(l.position_m.x());
      flash_top.y.push_back(l.position_m.y());
      flash_z.x.push_back(l.time_s);
      flash_z.y.push_back(l.position_m.z());
    }
  }
  PlotOptions top{"Trajectories seen from above (board in beige)", "x (m)", "y (m)", 460, 420};
  top.equal_aspect = true;
  const double hx = 0.5 * cameras.board.squares_x * cameras.board.square_length_m;
  const double hy = 0.5 * cameras.board.squares_y * cameras.board.square_length_m;
  top.outlines.push_back({{-hx, -hy}, {hx, -hy}, {hx, hy}, {-hx, hy}});
  const PlotOptions height{"Height above the board over time", "time on the common clock (s)", "z (m)", 560, 420};
  html += "<h3>Camera and light trajectories</h3>\n";
  std::vector<PlotSeries> top_series = {view_top, light_top, flash_top};
  if (!geometry_top.x.empty()) top_series.push_back(geometry_top);
  html += FigureRow({Figure(context.WriteAsset("trajectories_top.svg", PlotSvg(top, top_series)),
                            "Camera centres of both phones and the interpolated flash positions (world frame, "
                            "metres)."),
                     Figure(context.WriteAsset("trajectories_height.svg",
                                               PlotSvg(height, {view_z, light_z, flash_z})),
                            "Heights over time.")});
  return section;
}

}  // namespace relit::report
