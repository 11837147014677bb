// What every report section gets: where the workspace and the report being
// written are, the options, and helpers that put assets (SVG plots, PNG
// thumbnails, mesh previews) into the report folder.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "report/html.h"
#include "report/report_options.h"

namespace relit::report {

class ReportContext {
 public:
  // `out` is the (temporary) report folder being written.
  ReportContext(std::filesystem::path workspace, std::filesystem::path out, const ReportOptions& options);

  const std::filesystem::path& workspace() const { return workspace_; }
  const ReportOptions& options() const { return options_; }
  // W/<relative>.
  std::filesystem::path Input(const std::string& relative) const { return workspace_ / relative; }
  bool Has(const std::string& relative) const;

  // Writes `content` to assets/<name>; returns "assets/<name>" for HTML.
  std::string WriteAsset(const std::string& name, const std::string& content);

  // Reads any image relit writes (8/16-bit PNG, EXR: shown sRGB-encoded),
  // scales it to `width_px` wide (0 = thumbnail_width_px) and writes
  // assets/<name>.png; returns its src. Throws relit::Error naming the file.
  std::string Thumbnail(const std::filesystem::path& source, const std::string& name, int width_px = 0);

  // Renders the mesh (OBJ/PLY, world frame) from `views` directions around
  // `centre_m` under a headlight with the project's path tracer; returns
  // the srcs of assets/<name>_<k>.png.
  std::vector<std::string> MeshPreviews(const std::filesystem::path& mesh, const Eigen::Vector3d& centre_m,
                                        double radius_m, const std::string& name);

  // Warnings for the summary at the top of the page (also logged).
  void AddWarning(const std::string& section, const std::string& text);
  const std::vector<std::string>& warnings() const { return warnings_; }

  // Facts other sections reuse: the object centre (proxy.json, else the
  // board origin) and where it came from.
  Eigen::Vector3d object_centre_m = Eigen::Vector3d::Zero();
  std::string object_centre_source = "board origin (no proxy.json yet)";
  double object_radius_m = 0;
  // Figures sections computed (e.g. "coverage"), kept in run.json.
  nlohmann::json results = nlohmann::json::object();

 private:
  std::filesystem::path workspace_;
  std::filesystem::path out_;
  const ReportOptions& options_;
  std::vector<std::string> warnings_;
};

// Reads a JSON file with any schema (stage files the report shows as they
// are); relit::Error naming the file on a parse error.
nlohmann::json ReadAnyJson(const std::filesystem::path& path);

// Evenly spread picks of `count` of `total` indices (all when total <= count).
std::vector<size_t> EvenlySpread(size_t total, size_t count);

}  // namespace relit::report
