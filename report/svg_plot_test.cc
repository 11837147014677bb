// The SVG plot writer against known answers: tick values, the equal-area
// projection, where a point lands in the plot, escaping, gaps and layout
// edges.
#include <cmath>
#include <regex>

#include <gtest/gtest.h>

#include "core/error.h"
#include "relight/partitions.h"
#include "report/svg_plot.h"

namespace relit::report {
namespace {

constexpr double kPi = 3.14159265358979323846;

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(NiceTicks, KnownAnswers) {
  const std::vector<double> unit = NiceTicks(0, 1, 5);
  ASSERT_EQ(unit.size(), 6u);
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(unit[k], 0.2 * k, 1e-12);
  const std::vector<double> t = NiceTicks(0, 97, 5);
  ASSERT_EQ(t.size(), 5u);
  EXPECT_DOUBLE_EQ(t[1] - t[0], 20);
  EXPECT_DOUBLE_EQ(t.back(), 80);
  const std::vector<double> negative = NiceTicks(-0.013, 0.021, 4);
  EXPECT_DOUBLE_EQ(negative.front(), -0.01);
  EXPECT_DOUBLE_EQ(negative.back(), 0.02);
  EXPECT_EQ(negative.size(), 4u);  // step 0.01
  EXPECT_FALSE(NiceTicks(3, 3).empty());
  EXPECT_THROW(NiceTicks(2, 1), Error);
}

TEST(HemisphereProject, EqualAreaKnownAnswers) {
  EXPECT_NEAR(HemisphereProject({0, 0, 1}).norm(), 0, 1e-12);
  const Eigen::Vector2d horizon = HemisphereProject({1, 0, 0});
  EXPECT_NEAR(horizon.x(), 1, 1e-12);
  EXPECT_NEAR(horizon.y(), 0, 1e-12);
  // 30 deg elevation towards +Y: r^2 = 1 - cos(60 deg) = 0.5.
  const Eigen::Vector2d p = HemisphereProject({0, std::cos(kPi / 6), std::sin(kPi / 6)});
  EXPECT_NEAR(p.x(), 0, 1e-12);
  EXPECT_NEAR(p.y(), std::sqrt(0.5), 1e-12);
  // Equal area: the disc inside r holds the solid-angle fraction 1 - cos(polar) of the hemisphere.
  for (double polar = 0.05; polar < kPi / 2; polar += 0.2) {
    const double r = HemisphereProject({std::sin(polar), 0, std::cos(polar)}).norm();
    EXPECT_NEAR(r * r, 1 - std::cos(polar), 1e-12);
  }
  EXPECT_NEAR(HemisphereProject({0, 0, -2}).norm(), std::sqrt(2.0), 1e-12);
  EXPECT_THROW(HemisphereProject({0, 0, 0}), Error);
}

TEST(PlotSvg, PointLandsWhereTheAxesSay) {
  PlotOptions o;
  o.title = "a <b> & 'c'";
  o.x_min = 0;
  o.x_max = 10;
  o.y_min = 0;
  o.y_max = 10;
  PlotSeries s;
  s.label = "s";
  s.x = {5, 10};
  s.y = {5, 0};
  s.line = false;
  s.markers = true;
  const std::string svg = PlotSvg(o, {s});
  EXPECT_EQ(svg.rfind("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"560\" height=\"300\"", 0), 0u);
  // Plot area: x from 62 to 546 (width 484), y from 28 to 260 (height 232).
  EXPECT_NE(svg.find("cx=\"304\" cy=\"144\""), std::string::npos) << svg;
  EXPECT_NE(svg.find("cx=\"546\" cy=\"260\""), std::string::npos);
  EXPECT_NE(svg.find("a &lt;b&gt; &amp; &#39;c&#39;"), std::string::npos);
  EXPECT_EQ(svg.find("<b>"), std::string::npos);
  EXPECT_EQ(Count(svg, "<circle"), 2);
  EXPECT_EQ(svg.substr(svg.size() - 7), "</svg>\n");
}

TEST(PlotSvg, GapsSplitLinesAndLogScaleSkipsNonPositive) {
  PlotOptions o;
  PlotSeries line{"line", {0, 1, 2, 3, 4}, {1, 2, NAN, 3, 4}};
  EXPECT_EQ(Count(PlotSvg(o, {line}), "<polyline"), 2);
  o.log_y = true;
  PlotSeries dots{"dots", {0, 1, 2, 3}, {1, 0, -1, 10}, "", false, true};
  const std::string svg = PlotSvg(o, {dots});
  EXPECT_EQ(Count(svg, "<circle"), 2);
  EXPECT_NE(svg.find(">10</text>"), std::string::npos);  // decade ticks 1 and 10
  PlotSeries empty{"nothing", {}, {}};
  EXPECT_NE(PlotSvg(PlotOptions{}, {empty}).find("nothing (no data)"), std::string::npos);
  PlotSeries bad{"bad", {0, 1}, {0}};
  EXPECT_THROW(PlotSvg(PlotOptions{}, {bad}), Error);
}

TEST(HemisphereSvg, DrawsEachLayoutEdgeOnceAndPointsInPlace) {
  HemisphereOptions o;
  o.title = "t";
  o.layout_vertices = {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}};
  o.layout_triangles = {{0, 1, 2}, {0, 2, 3}};  // 5 distinct edges
  const std::string svg = HemisphereSvg(o, {{"view", {{0, 0, 1}}, "#123456", 3}});
  EXPECT_EQ(Count(svg, "stroke-dasharray"), 5);
  // size 420, title row 26: the zenith is at (210, 236).
  EXPECT_NE(svg.find("cx=\"210\" cy=\"236\" r=\"3\" fill=\"#123456\""), std::string::npos) << svg;
  // The DNL layout: 18 triangles, each edge drawn once (V - E + F = 1 for the
  // open triangulated disc: E = 13 + 18 - 1 = 30).
  const relight::PartitionLayout dnl = relight::PartitionLayout::Dnl13();
  HemisphereOptions d;
  d.layout_vertices = dnl.vertices();
  d.layout_triangles = dnl.triangles();
  EXPECT_EQ(dnl.triangles().size(), 18u);
  EXPECT_EQ(Count(HemisphereSvg(d, {}), "stroke-dasharray"), 30);
  o.layout_triangles = {{0, 1, 7}};
  EXPECT_THROW(HemisphereSvg(o, {}), Error);
}

}  // namespace
}  // namespace relit::report
