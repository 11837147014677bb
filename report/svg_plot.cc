#include "report/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <sstream>

#include "core/error.h"

namespace relit::report {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Coordinates with two decimals keep the files small and exact enough.
std::string Num(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f", value);
  std::string s = text;
  while (!s.empty() && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s == "-0" ? "0" : s;
}

// A tick label with as many decimals as the tick step needs.
std::string TickLabel(double value, double step) {
  const int decimals = std::clamp(static_cast<int>(-std::floor(std::log10(step) + 1e-9)), 0, 8);
  char text[48];
  if (std::abs(value) >= 1e6 || (std::abs(value) > 0 && std::abs(value) < 1e-4)) {
    std::snprintf(text, sizeof(text), "%.2g", value);
  } else {
    std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  }
  std::string s = text;
  return s == "-0" ? "0" : s;
}

std::string Header(int width, int height) {
  std::ostringstream out;
  out << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
      << "\" viewBox=\"0 0 " << width << " " << height << "\" font-family=\"sans-serif\" font-size=\"11\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  return out.str();
}

std::string Text(double x, double y, const std::string& text, const std::string& anchor = "middle",
                 const std::string& extra = "") {
  std::ostringstream out;
  out << "<text x=\"" << Num(x) << "\" y=\"" << Num(y) << "\" text-anchor=\"" << anchor << "\"" << extra << ">"
      << XmlEscape(text) << "</text>\n";
  return out.str();
}

struct Range {
  double min = std::numeric_limits<double>::infinity();
  double max = -std::numeric_limits<double>::infinity();
  void Add(double v) {
    if (!std::isfinite(v)) return;
    min = std::min(min, v);
    max = std::max(max, v);
  }
  bool valid() const { return min <= max; }
};

}  // namespace

std::string XmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::vector<double> NiceTicks(double min, double max, int target_count) {
  RELIT_REQUIRE(std::isfinite(min) && std::isfinite(max) && min <= max, "NiceTicks: bad range [", min, ", ",
                max, "]");
  if (max - min < 1e-12 * std::max(1.0, std::abs(min))) {
    const double pad = std::abs(min) > 0 ? std::abs(min) * 0.1 : 1.0;
    min -= pad;
    max += pad;
  }
  const double raw_step = (max - min) / std::max(1, target_count);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw_step)));
  double step = magnitude;
  for (const double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * magnitude;
    if (step >= raw_step * 0.999) break;
  }
  std::vector<double> ticks;
  const double first = std::ceil(min / step - 1e-9);
  for (double k = first; k * step <= max + step * 1e-9; k += 1) {
    const double v = k * step;
    ticks.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
  }
  return ticks;
}

const char* SeriesColour(int index) {
  static const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                                   "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
  return kColours[((index % 10) + 10) % 10];
}

std::string PlotSvg(const PlotOptions& options, const std::vector<PlotSeries>& series) {
  RELIT_REQUIRE(options.width_px > 0 && options.height_px > 0, "plot '", options.title, "': size must be positive");
  const double left = 62, right = 14, top = options.title.empty() ? 12 : 28, bottom = 40;
  const double plot_w = options.width_px - left - right, plot_h = options.height_px - top - bottom;
  RELIT_REQUIRE(plot_w > 10 && plot_h > 10, "plot '", options.title, "' is too small");
  auto ty = [&](double y) { return options.log_y ? (y > 0 ? std::log10(y) : NAN) : y; };

  Range xr, yr;
  for (const PlotSeries& s : series) {
    RELIT_REQUIRE(s.x.size() == s.y.size(), "plot '", options.title, "': series '", s.label,
                  "' has x and y of different lengths");
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(ty(s.y[i]))) continue;
      xr.Add(s.x[i]);
      yr.Add(ty(s.y[i]));
      if (s.stems && !options.log_y) yr.Add(0.0);
    }
  }
  for (const auto& outline : options.outlines) {
    for (const Eigen::Vector2d& p : outline) {
      xr.Add(p.x());
      yr.Add(ty(p.y()));
    }
  }
  if (!xr.valid()) xr = Range{0, 1};
  if (!yr.valid()) yr = Range{0, 1};
  // A margin of 3% so markers at the extremes are not cut by the frame.
  const double x_pad = 0.03 * (xr.max - xr.min), y_pad = 0.03 * (yr.max - yr.min);
  xr = Range{xr.min - x_pad, xr.max + x_pad};
  if (!options.log_y) yr = Range{yr.min - y_pad, yr.max + y_pad};
  if (std::isfinite(options.x_min)) xr.min = options.x_min;
  if (std::isfinite(options.x_max)) xr.max = options.x_max;
  if (std::isfinite(options.y_min)) yr.min = ty(options.y_min);
  if (std::isfinite(options.y_max)) yr.max = ty(options.y_max);
  // Pad to nice tick bounds so the data does not touch the frame.
  std::vector<double> xticks = NiceTicks(xr.min, xr.max, std::max(2, static_cast<int>(plot_w / 80)));
  std::vector<double> yticks;
  if (options.log_y) {
    yr.min = std::floor(yr.min);
    yr.max = std::max(yr.min + 1, std::ceil(yr.max));
    for (double k = yr.min; k <= yr.max + 1e-9; k += 1) yticks.push_back(k);
  } else {
    yticks = NiceTicks(yr.min, yr.max, std::max(2, static_cast<int>(plot_h / 50)));
    if (!std::isfinite(options.y_min)) yr.min = std::min(yr.min, yticks.front());
    if (!std::isfinite(options.y_max)) yr.max = std::max(yr.max, yticks.back());
  }
  if (!std::isfinite(options.x_min)) xr.min = std::min(xr.min, xticks.front());
  if (!std::isfinite(options.x_max)) xr.max = std::max(xr.max, xticks.back());
  if (xr.max - xr.min <= 0) xr.max = xr.min + 1;
  if (yr.max - yr.min <= 0) yr.max = yr.min + 1;
  if (options.equal_aspect) {
    // Widen the tighter axis so one data unit is the same length on both.
    const double scale = std::max((xr.max - xr.min) / plot_w, (yr.max - yr.min) / plot_h);
    const double xc = 0.5 * (xr.min + xr.max), yc = 0.5 * (yr.min + yr.max);
    xr = Range{xc - 0.5 * scale * plot_w, xc + 0.5 * scale * plot_w};
    yr = Range{yc - 0.5 * scale * plot_h, yc + 0.5 * scale * plot_h};
    xticks = NiceTicks(xr.min, xr.max, std::max(2, static_cast<int>(plot_w / 80)));
    yticks = NiceTicks(yr.min, yr.max, std::max(2, static_cast<int>(plot_h / 50)));
  }
  auto px = [&](double x) { return left + (x - xr.min) / (xr.max - xr.min) * plot_w; };
  auto py = [&](double y) { return top + plot_h - (y - yr.min) / (yr.max - yr.min) * plot_h; };

  std::ostringstream out;
  out << Header(options.width_px, options.height_px);
  out << "<defs><clipPath id=\"plot-area\"><rect x=\"" << Num(left) << "\" y=\"" << Num(top) << "\" width=\""
      << Num(plot_w) << "\" height=\"" << Num(plot_h) << "\"/></clipPath></defs>\n";
  if (!options.title.empty()) out << Text(options.width_px / 2.0, 17, options.title, "middle", " font-size=\"13\"");
  // Grid and tick labels.
  const double xstep = xticks.size() > 1 ? xticks[1] - xticks[0] : 1;
  for (const double t : xticks) {
    if (t < xr.min - 1e-9 || t > xr.max + 1e-9) continue;
    out << "<line x1=\"" << Num(px(t)) << "\" y1=\"" << Num(top) << "\" x2=\"" << Num(px(t)) << "\" y2=\""
        << Num(top + plot_h) << "\" stroke=\"#e4e4e4\"/>\n";
    out << Text(px(t), top + plot_h + 14, TickLabel(t, xstep));
  }
  const double ystep = yticks.size() > 1 ? yticks[1] - yticks[0] : 1;
  for (const double t : yticks) {
    if (t < yr.min - 1e-9 || t > yr.max + 1e-9) continue;
    out << "<line x1=\"" << Num(left) << "\" y1=\"" << Num(py(t)) << "\" x2=\"" << Num(left + plot_w) << "\" y2=\""
        << Num(py(t)) << "\" stroke=\"#e4e4e4\"/>\n";
    const std::string label = options.log_y ? TickLabel(std::pow(10.0, t), std::pow(10.0, t)) : TickLabel(t, ystep);
    out << Text(left - 5, py(t) + 4, label, "end");
  }
  out << "<rect x=\"" << Num(left) << "\" y=\"" << Num(top) << "\" width=\"" << Num(plot_w) << "\" height=\""
      << Num(plot_h) << "\" fill=\"none\" stroke=\"#444\"/>\n";
  if (!options.x_label.empty()) out << Text(left + plot_w / 2, options.height_px - 8, options.x_label);
  if (!options.y_label.empty()) {
    out << "<text transform=\"translate(14," << Num(top + plot_h / 2) << ") rotate(-90)\" text-anchor=\"middle\">"
        << XmlEscape(options.y_label) << "</text>\n";
  }

  out << "<g clip-path=\"url(#plot-area)\">\n";
  for (const auto& outline : options.outlines) {
    if (outline.size() < 2) continue;
    out << "<polygon fill=\"#f3efe0\" stroke=\"#a89f80\" points=\"";
    for (const Eigen::Vector2d& p : outline) out << Num(px(p.x())) << "," << Num(py(ty(p.y()))) << " ";
    out << "\"/>\n";
  }
  for (size_t k = 0; k < series.size(); ++k) {
    const PlotSeries& s = series[k];
    const std::string colour = s.colour.empty() ? SeriesColour(static_cast<int>(k)) : s.colour;
    if (s.line) {
      std::string points;
      auto flush = [&]() {
        if (!points.empty()) {
          out << "<polyline fill=\"none\" stroke=\"" << colour << "\" stroke-width=\"1.5\" points=\"" << points
              << "\"/>\n";
        }
        points.clear();
      };
      for (size_t i = 0; i < s.x.size(); ++i) {
        const double y = ty(s.y[i]);
        if (!std::isfinite(s.x[i]) || !std::isfinite(y)) {
          flush();
          continue;
        }
        points += Num(px(s.x[i])) + "," + Num(py(y)) + " ";
      }
      flush();
    }
    for (size_t i = 0; i < s.x.size(); ++i) {
      const double y = ty(s.y[i]);
      if (!std::isfinite(s.x[i]) || !std::isfinite(y)) continue;
      if (s.stems) {
        out << "<line x1=\"" << Num(px(s.x[i])) << "\" y1=\"" << Num(py(std::max(yr.min, 0.0))) << "\" x2=\""
            << Num(px(s.x[i])) << "\" y2=\"" << Num(py(y)) << "\" stroke=\"" << colour << "\" stroke-width=\"2\"/>\n";
      }
      if (s.markers) {
        out << "<circle cx=\"" << Num(px(s.x[i])) << "\" cy=\"" << Num(py(y)) << "\" r=\"" << Num(s.marker_radius_px)
            << "\" fill=\"" << colour << "\"/>\n";
      }
    }
  }
  out << "</g>\n";
  // Legend, top right inside the frame.
  double ly = top + 14;
  for (size_t k = 0; k < series.size(); ++k) {
    const PlotSeries& s = series[k];
    if (s.label.empty()) continue;
    bool any = false;
    for (size_t i = 0; i < s.x.size() && !any; ++i) any = std::isfinite(s.x[i]) && std::isfinite(ty(s.y[i]));
    const std::string colour = s.colour.empty() ? SeriesColour(static_cast<int>(k)) : s.colour;
    const double lx = left + plot_w - 8;
    out << "<rect x=\"" << Num(lx - 4) << "\" y=\"" << Num(ly - 8) << "\" width=\"10\" height=\"10\" fill=\""
        << colour << "\"/>\n";
    out << Text(lx - 10, ly + 1, s.label + (any ? "" : " (no data)"), "end",
                " paint-order=\"stroke\" stroke=\"white\" stroke-width=\"3\"");
    ly += 15;
  }
  out << "</svg>\n";
  return out.str();
}

Eigen::Vector2d HemisphereProject(const Eigen::Vector3d& direction) {
  const double norm = direction.norm();
  RELIT_REQUIRE(norm > 0 && std::isfinite(norm), "HemisphereProject: zero or non-finite direction");
  const Eigen::Vector3d d = direction / norm;
  const double polar = std::acos(std::clamp(d.z(), -1.0, 1.0));
  // Lambert equal-area: r = 2 sin(polar / 2), scaled so the horizon is at 1.
  const double r = 2.0 * std::sin(polar / 2.0) / std::sqrt(2.0);
  const double azimuth = std::atan2(d.y(), d.x());
  return {r * std::cos(azimuth), r * std::sin(azimuth)};
}

std::string HemisphereSvg(const HemisphereOptions& options, const std::vector<HemisphereSeries>& series) {
  RELIT_REQUIRE(options.size_px >= 120, "hemisphere plot '", options.title, "' is too small");
  const double top = options.title.empty() ? 8 : 26;
  const double legend_h = 16.0 * series.size() + 8;
  const double width = options.size_px, height = options.size_px + top + legend_h;
  const double cx = width / 2, cy = top + options.size_px / 2.0;
  // Directions below the horizon reach radius sqrt(2); leave room for a bit of that.
  const double radius = options.size_px / 2.0 - 22;
  auto map = [&](const Eigen::Vector3d& d) {
    Eigen::Vector2d p = HemisphereProject(d);
    const double r = p.norm();
    if (r > 1.08) p *= 1.08 / r;  // far below the horizon: pinned just outside the rim
    return Eigen::Vector2d(cx + radius * p.x(), cy - radius * p.y());
  };

  std::ostringstream out;
  out << Header(static_cast<int>(width), static_cast<int>(height));
  if (!options.title.empty()) out << Text(width / 2, 17, options.title, "middle", " font-size=\"13\"");
  // Elevation rings every 30 degrees, azimuth spokes every 45 degrees.
  for (const double elevation : {0.0, 30.0, 60.0}) {
    const double r = radius * HemisphereProject({std::cos(elevation * kPi / 180), 0,
                                                 std::sin(elevation * kPi / 180)}).norm();
    out << "<circle cx=\"" << Num(cx) << "\" cy=\"" << Num(cy) << "\" r=\"" << Num(r) << "\" fill=\""
        << (elevation == 0 ? "#fafafa" : "none") << "\" stroke=\"" << (elevation == 0 ? "#555" : "#ccc") << "\"/>\n";
    // Labelled at azimuth -15 deg, between the vertices of the DNL layout.
    const double label_azimuth = -15 * kPi / 180;
    out << Text(cx + (r - 2) * std::cos(label_azimuth), cy - (r - 2) * std::sin(label_azimuth) + 3,
                Num(elevation) + "°", "end", " fill=\"#888\" font-size=\"9\"");
  }
  for (int k = 0; k < 8; ++k) {
    const double a = k * kPi / 4;
    const Eigen::Vector2d rim = map({std::cos(a), std::sin(a), 0});
    out << "<line x1=\"" << Num(cx) << "\" y1=\"" << Num(cy) << "\" x2=\"" << Num(rim.x()) << "\" y2=\""
        << Num(rim.y()) << "\" stroke=\"#e4e4e4\"/>\n";
  }
  out << Text(cx + radius + 4, cy + 16, "+X", "start", " fill=\"#555\"");
  out << Text(cx + 12, cy - radius - 4, "+Y", "start", " fill=\"#555\"");
  // Partition triangles as great-circle arcs.
  const auto& v = options.layout_vertices;
  std::set<std::pair<int, int>> edges_drawn;
  for (const auto& tri : options.layout_triangles) {
    for (int e = 0; e < 3; ++e) {
      const int a = tri[e], b = tri[(e + 1) % 3];
      RELIT_REQUIRE(a >= 0 && b >= 0 && a < static_cast<int>(v.size()) && b < static_cast<int>(v.size()),
                    "hemisphere plot: triangle refers to vertex outside the layout");
      if (!edges_drawn.insert({std::min(a, b), std::max(a, b)}).second) continue;  // shared edges once
      const Eigen::Vector3d va = v[a].normalized(), vb = v[b].normalized();
      std::string points;
      for (int i = 0; i <= 16; ++i) {
        const double t = i / 16.0;
        const Eigen::Vector3d d = ((1 - t) * va + t * vb);
        if (d.norm() < 1e-9) continue;
        const Eigen::Vector2d p = map(d);
        points += Num(p.x()) + "," + Num(p.y()) + " ";
      }
      out << "<polyline fill=\"none\" stroke=\"#9a9a9a\" stroke-dasharray=\"4,3\" points=\"" << points << "\"/>\n";
    }
  }
  if (options.link_first_two_series && series.size() >= 2) {
    const size_t n = std::min(series[0].directions.size(), series[1].directions.size());
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Vector2d a = map(series[0].directions[i]), b = map(series[1].directions[i]);
      out << "<line x1=\"" << Num(a.x()) << "\" y1=\"" << Num(a.y()) << "\" x2=\"" << Num(b.x()) << "\" y2=\""
          << Num(b.y()) << "\" stroke=\"#bbb\" stroke-width=\"0.6\"/>\n";
    }
  }
  for (size_t k = 0; k < series.size(); ++k) {
    const HemisphereSeries& s = series[k];
    const std::string colour = s.colour.empty() ? SeriesColour(static_cast<int>(k)) : s.colour;
    for (const Eigen::Vector3d& d : s.directions) {
      const Eigen::Vector2d p = map(d);
      out << "<circle cx=\"" << Num(p.x()) << "\" cy=\"" << Num(p.y()) << "\" r=\"" << Num(s.marker_radius_px)
          << "\" fill=\"" << colour << "\" fill-opacity=\"0.8\"/>\n";
    }
    const double ly = top + options.size_px + 14 + 16.0 * k;
    out << "<rect x=\"12\" y=\"" << Num(ly - 9) << "\" width=\"10\" height=\"10\" fill=\"" << colour << "\"/>\n";
    out << Text(28, ly, s.label + " (" + std::to_string(s.directions.size()) + ")", "start");
  }
  for (size_t i = 0; i < v.size(); ++i) {
    const Eigen::Vector2d p = map(v[i]);
    out << "<circle cx=\"" << Num(p.x()) << "\" cy=\"" << Num(p.y()) << "\" r=\"7\" fill=\"white\" stroke=\"#333\"/>\n";
    out << Text(p.x(), p.y() + 3.5, std::to_string(i), "middle", " font-size=\"9\"");
  }
  out << "</svg>\n";
  return out.str();
}

}  // namespace relit::report
