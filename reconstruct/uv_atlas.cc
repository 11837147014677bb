// UV atlas: chart growing, LSCM with re-splitting, packing, OBJ output.
#include "reconstruct/uv_atlas.h"

#include <chrono>
#include <cmath>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>

#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/run_record.h"
#include "reconstruct/atlas_internal.h"

namespace relit::reconstruct {
namespace {

// Exact planar layout of one triangle (never fails, never flips).
void LayOutTriangle(const render::TriangleMesh& mesh, atlas::Chart* chart) {
  const Eigen::Vector3i& t = mesh.triangles[chart->faces[0]];
  const Eigen::Vector3d a = mesh.positions[t[0]].cast<double>(), b = mesh.positions[t[1]].cast<double>(),
                        c = mesh.positions[t[2]].cast<double>();
  const double ab = std::max((b - a).norm(), 1e-9);
  const Eigen::Vector3d x = (b - a) / ab;
  const double cx = (c - a).dot(x);
  const double cy = std::max((c - a - cx * x).norm(), 1e-9);
  chart->uv[chart->triangles[0][0]] = {0, 0};
  chart->uv[chart->triangles[0][1]] = {ab, 0};
  chart->uv[chart->triangles[0][2]] = {cx, cy};
}

}  // namespace

// The JSON keys are the members' names.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(AtlasStats, charts, chart_splits, chart_merges, flipped_triangles,
                                   degenerate_triangles, overlapping_texels, chart_contact_texels,
                                   min_chart_gap_texels, utilisation, stretch_l2_mean, stretch_l2_max,
                                   stretch_area_ratio_p95, texels_per_metre)

nlohmann::json AtlasStats::ToJson() const { return *this; }

namespace atlas {

bool ParameterizeChart(const render::TriangleMesh& mesh, std::vector<int> faces, double max_stretch, Chart* chart,
                       ChartQuality* quality) {
  const bool single = faces.size() == 1;
  *chart = MakeChart(mesh, faces);
  if (single) {
    LayOutTriangle(mesh, chart);
  } else {
    // Handles (noisy fused surfaces have many tiny tunnels) and enclosed
    // holes are cut open along a minimal cut graph.
    if (!IsDisc(*chart)) *chart = MakeChart(mesh, faces, CutToDisc(mesh, faces));
    if (!IsDisc(*chart) || !ParameterizeLscm(mesh, chart)) return false;
  }
  *quality = NormaliseAndEvaluate(mesh, chart);
  return single || (quality->flipped == 0 && quality->degenerate == 0 && !quality->overlaps &&
                    quality->stretch_l2 <= max_stretch);
}

}  // namespace atlas

UvAtlas BuildAtlas(const render::TriangleMesh& mesh, const AtlasOptions& options, AtlasStats* stats) {
  CheckOptions(options, "atlas");
  RELIT_REQUIRE(!mesh.triangles.empty(), "reconstruct: cannot build a UV atlas for an empty mesh");
  const auto start = std::chrono::steady_clock::now();
  auto seconds = [&] { return SecondsSince(start); };
  const atlas::FaceGraph graph = atlas::BuildFaceGraph(mesh);
  std::deque<std::vector<int>> queue;
  for (auto& faces : atlas::GrowCharts(mesh, graph, options)) queue.push_back(std::move(faces));
  const int grown = static_cast<int>(queue.size());
  std::vector<atlas::Chart> charts;
  int splits = 0;
  while (!queue.empty()) {
    std::vector<int> faces = std::move(queue.front());
    queue.pop_front();
    atlas::Chart chart;
    atlas::ChartQuality quality;
    if (atlas::ParameterizeChart(mesh, faces, options.max_stretch, &chart, &quality)) {
      charts.push_back(std::move(chart));
      continue;
    }
    ++splits;
    for (auto& piece : atlas::SplitFaces(faces, graph)) queue.push_back(std::move(piece));
  }
  const int after_splits = static_cast<int>(charts.size());
  const double split_seconds = seconds();
  int merges = 0;
  if (options.merge_charts) {
    merges = atlas::MergeCharts(mesh, graph, options.max_chart_faces, options.merge_max_stretch, &charts);
  }
  const double merge_seconds = seconds() - split_seconds;
  UvAtlas out;
  out.resolution_px = options.resolution_px;
  out.gutter_px = options.gutter_px;
  out.chart_count = static_cast<int>(charts.size());
  double texels_per_metre = 0;
  const double pack_start = seconds();
  RELIT_REQUIRE(atlas::PackCharts(&charts, options.resolution_px, options.gutter_px, &texels_per_metre),
                "reconstruct: ", charts.size(), " charts do not fit into a ", options.resolution_px,
                "^2 atlas with ", options.gutter_px, " gutter texels; lower cleanup.target_faces or raise "
                "atlas.resolution_px");
  const double pack_seconds = seconds() - pack_start;
  out.face_chart.assign(mesh.triangles.size(), -1);
  out.corner_uvs.assign(3 * mesh.triangles.size(), Eigen::Vector2f::Zero());
  for (std::size_t c = 0; c < charts.size(); ++c) {
    for (std::size_t i = 0; i < charts[c].faces.size(); ++i) {
      const int f = charts[c].faces[i];
      out.face_chart[f] = static_cast<int>(c);
      for (int k = 0; k < 3; ++k) out.corner_uvs[3 * f + k] = charts[c].uv[charts[c].triangles[i][k]].cast<float>();
    }
  }
  for (int c : out.face_chart) RELIT_CHECK(c >= 0);
  *stats = MeasureAtlas(mesh, out);
  stats->chart_splits = splits;
  stats->chart_merges = merges;
  spdlog::info("atlas: {} charts grown, {} after {} splits, {} after {} merges, utilisation {:.1f}%, L2 stretch "
               "{:.3f} (max {:.2f}), {} flipped, {} overlapping texels; {:.1f} s growing and splitting, {:.1f} s "
               "merging, {:.1f} s packing",
               grown, after_splits, splits, out.chart_count, merges, 100 * stats->utilisation,
               stats->stretch_l2_mean, stats->stretch_l2_max, stats->flipped_triangles, stats->overlapping_texels,
               split_seconds, merge_seconds, pack_seconds);
  return out;
}

void WriteObjWithAtlas(const std::string& path, const render::TriangleMesh& mesh, const UvAtlas& atlas) {
  const std::filesystem::path p(path);
  const std::string mtl_name = p.stem().string() + ".mtl";
  {
    std::ofstream mtl(p.parent_path() / mtl_name);
    mtl << "# relit proxy material (the neural texture replaces it)\nnewmtl proxy\nKd 0.8 0.8 0.8\n";
    RELIT_REQUIRE(mtl.good(), "reconstruct: cannot write ", (p.parent_path() / mtl_name).string());
  }
  std::ofstream obj(path);
  obj.precision(9);
  obj << "# relit proxy mesh: world (board) frame, metres; per-corner UVs for a " << atlas.resolution_px
      << "^2 atlas\nmtllib " << mtl_name << "\nusemtl proxy\n";
  for (const Eigen::Vector3f& v : mesh.positions) obj << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
  // (chart, vertex, uv) -> vt: a chart may hold two copies of a vertex where
  // it touches itself.
  std::map<std::tuple<int, int, float, float>, int> vt_index;
  std::vector<int> corner_vt(atlas.corner_uvs.size());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2f& uv = atlas.corner_uvs[3 * f + k];
      const auto [it, inserted] = vt_index.emplace(
          std::make_tuple(atlas.face_chart[f], mesh.triangles[f][k], uv.x(), uv.y()), static_cast<int>(vt_index.size()));
      if (inserted) {
        obj << "vt " << uv.x() << ' ' << uv.y() << '\n';
      }
      corner_vt[3 * f + k] = it->second;
    }
  }
  const bool normals = mesh.has_normals();
  if (normals) {
    for (const Eigen::Vector3f& n : mesh.normals) obj << "vn " << n.x() << ' ' << n.y() << ' ' << n.z() << '\n';
  }
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    obj << 'f';
    for (int k = 0; k < 3; ++k) {
      const int v = mesh.triangles[f][k] + 1;
      obj << ' ' << v << '/' << corner_vt[3 * f + k] + 1;
      if (normals) obj << '/' << v;
    }
    obj << '\n';
  }
  RELIT_REQUIRE(obj.good(), "reconstruct: cannot write ", path);
}

}  // namespace relit::reconstruct
