// Small SVG plot writer for the offline report: line/scatter plots with
// axes, ticks and a legend, and a hemisphere plot (azimuthal equal-area
// projection of the upper hemisphere seen from above) for view and light
// directions with the partition layout. Output is a complete standalone SVG
// document with explicit width/height (so browsers give it a natural size).
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace relit::report {

// Escapes &, <, >, " and ' for XML/HTML text and attribute values.
std::string XmlEscape(const std::string& text);

// "Nice" tick values (steps of 1, 2 or 5 x 10^k) covering [min, max] with
// about `target_count` ticks; min/max themselves need not be ticks.
// A degenerate range (min == max) is widened around the value.
std::vector<double> NiceTicks(double min, double max, int target_count = 5);

// Distinct colours for series, cycling.
const char* SeriesColour(int index);

struct PlotSeries {
  // Default initialisers let callers brace-initialise only the first fields.
  std::string label = "";
  std::vector<double> x = {}, y = {};  // same length; non-finite points are skipped
  std::string colour = "";             // empty: SeriesColour(series index)
  bool line = true;           // polyline through the points (broken at gaps)
  bool markers = false;       // a dot per point
  double marker_radius_px = 2.5;
  bool stems = false;         // vertical line from y = 0 to each point
};

struct PlotOptions {
  std::string title;
  std::string x_label, y_label;
  int width_px = 560;
  int height_px = 300;
  bool log_y = false;             // base-10; non-positive values are skipped
  bool equal_aspect = false;      // same scale on both axes (maps, top views)
  // Fixed axis ranges (NaN = from the data).
  double x_min = NAN, x_max = NAN, y_min = NAN, y_max = NAN;
  // Outlines drawn under the data (e.g. the board), in data coordinates.
  std::vector<std::vector<Eigen::Vector2d>> outlines = {};
};

// A complete SVG document. Series without a finite point are listed in the
// legend as "(no data)". Throws relit::Error when sizes are not positive.
std::string PlotSvg(const PlotOptions& options, const std::vector<PlotSeries>& series);

// Lambert azimuthal equal-area projection of a direction (need not be unit,
// +Z up) onto the unit disc: zenith -> (0, 0), horizon -> radius 1, azimuth
// measured from +X towards +Y. Directions below the horizon land outside
// the unit disc (radius up to sqrt(2) at the nadir).
Eigen::Vector2d HemisphereProject(const Eigen::Vector3d& direction);

struct HemisphereSeries {
  std::string label = "";
  std::vector<Eigen::Vector3d> directions = {};
  std::string colour = "";
  double marker_radius_px = 3;
};

struct HemisphereOptions {
  std::string title;
  int size_px = 420;
  // Partition layout: vertices (unit directions) and triangles between them,
  // drawn as great-circle arcs; vertices labelled with their index.
  std::vector<Eigen::Vector3d> layout_vertices;
  std::vector<std::array<int, 3>> layout_triangles;
  // Thin lines joining series 0 and series 1 point by point (view -> light
  // of the same frame), to show how the two move together.
  bool link_first_two_series = false;
};

std::string HemisphereSvg(const HemisphereOptions& options, const std::vector<HemisphereSeries>& series);

}  // namespace relit::report
