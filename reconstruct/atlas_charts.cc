// Chart growing, chart topology, splitting and per-chart quality of the UV atlas.
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <queue>
#include <unordered_map>

#include <Eigen/Eigenvalues>

#include "core/error.h"
#include "reconstruct/atlas_internal.h"

namespace relit::reconstruct::atlas {
namespace {

uint64_t EdgeKey(int a, int b) {
  return (static_cast<uint64_t>(std::min(a, b)) << 32) | static_cast<uint32_t>(std::max(a, b));
}

double Cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

}  // namespace

FaceGraph BuildFaceGraph(const render::TriangleMesh& mesh) {
  const int n = static_cast<int>(mesh.triangles.size());
  FaceGraph g;
  g.neighbours.assign(n, {-1, -1, -1});
  g.normals.resize(n);
  g.areas.resize(n);
  g.centroids.resize(n);
  std::unordered_map<uint64_t, std::vector<std::pair<int, int>>> edge_faces;
  for (int f = 0; f < n; ++f) {
    const Eigen::Vector3i& t = mesh.triangles[f];
    const Eigen::Vector3d a = mesh.positions[t[0]].cast<double>(), b = mesh.positions[t[1]].cast<double>(),
                          c = mesh.positions[t[2]].cast<double>();
    const Eigen::Vector3d cross = (b - a).cross(c - a);
    g.areas[f] = 0.5 * cross.norm();
    g.normals[f] = cross.norm() > 0 ? Eigen::Vector3d(cross.normalized()) : Eigen::Vector3d::UnitZ();
    g.centroids[f] = (a + b + c) / 3.0;
    for (int k = 0; k < 3; ++k) edge_faces[EdgeKey(t[k], t[(k + 1) % 3])].push_back({f, k});
  }
  for (const auto& [key, list] : edge_faces) {
    if (list.size() != 2) continue;  // border or non-manifold: a seam
    g.neighbours[list[0].first][list[0].second] = list[1].first;
    g.neighbours[list[1].first][list[1].second] = list[0].first;
  }
  return g;
}

Chart MakeChart(const render::TriangleMesh& mesh, std::vector<int> faces) {
  Chart chart;
  chart.faces = std::move(faces);
  std::unordered_map<int, int> local;
  for (int f : chart.faces) {
    Eigen::Vector3i t;
    for (int k = 0; k < 3; ++k) {
      const int v = mesh.triangles[f][k];
      auto [it, inserted] = local.emplace(v, static_cast<int>(chart.vertices.size()));
      if (inserted) chart.vertices.push_back(v);
      t[k] = it->second;
    }
    chart.triangles.push_back(t);
  }
  chart.uv.assign(chart.vertices.size(), Eigen::Vector2d::Zero());
  return chart;
}

std::vector<std::vector<int>> GrowCharts(const render::TriangleMesh& mesh, const FaceGraph& g,
                                         const AtlasOptions& options) {
  const int n = static_cast<int>(mesh.triangles.size());
  const double cos_max = std::cos(options.max_normal_deviation_deg * M_PI / 180.0);
  std::vector<int> chart_of(n, -1);
  std::vector<std::vector<int>> charts;
  // Seeds in order of decreasing area, so big flat regions start charts.
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return g.areas[a] > g.areas[b]; });
  using Entry = std::pair<double, int>;  // cost, face
  for (int seed : order) {
    if (chart_of[seed] >= 0) continue;
    const int id = static_cast<int>(charts.size());
    charts.push_back({seed});
    chart_of[seed] = id;
    Eigen::Vector3d normal_sum = g.normals[seed] * g.areas[seed];
    Eigen::Vector3d centroid_sum = g.centroids[seed] * g.areas[seed];
    double area = g.areas[seed];
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
    auto cost = [&](int f, double* deviation) {
      const Eigen::Vector3d mean_normal = normal_sum.normalized();
      *deviation = g.normals[f].dot(mean_normal);
      const double normal_cost = 1.0 - *deviation;
      const Eigen::Vector3d centre = centroid_sum / area;
      const double radius = std::sqrt(area / M_PI) + 1e-12;
      const double roundness_cost = (g.centroids[f] - centre).norm() / radius;
      int shared = 0;
      for (int k = 0; k < 3; ++k) shared += (g.neighbours[f][k] >= 0 && chart_of[g.neighbours[f][k]] == id);
      const double seam_cost = (3.0 - 2.0 * shared) / 3.0;  // boundary length added
      return normal_cost + options.roundness_weight * 0.1 * roundness_cost + options.seam_weight * 0.1 * seam_cost;
    };
    auto push_neighbours = [&](int f) {
      for (int k = 0; k < 3; ++k) {
        const int nb = g.neighbours[f][k];
        if (nb < 0 || chart_of[nb] >= 0) continue;
        double deviation;
        const double c = cost(nb, &deviation);
        if (deviation >= cos_max) queue.push({c, nb});
      }
    };
    push_neighbours(seed);
    while (!queue.empty() && static_cast<int>(charts[id].size()) < options.max_chart_faces) {
      const auto [old_cost, f] = queue.top();
      queue.pop();
      if (chart_of[f] >= 0) continue;
      double deviation;
      const double c = cost(f, &deviation);
      if (deviation < cos_max) continue;
      if (c > old_cost + 1e-9 && !queue.empty() && c > queue.top().first) {
        queue.push({c, f});  // lazily re-ranked
        continue;
      }
      chart_of[f] = id;
      charts[id].push_back(f);
      normal_sum += g.normals[f] * g.areas[f];
      centroid_sum += g.centroids[f] * g.areas[f];
      area += g.areas[f];
      push_neighbours(f);
    }
  }
  return charts;
}

bool IsDisc(const Chart& chart) {
  std::map<std::pair<int, int>, int> edge_count;
  for (const Eigen::Vector3i& t : chart.triangles) {
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      edge_count[{std::min(a, b), std::max(a, b)}] += 1;
    }
  }
  // Border edges form loops; count loops via border vertex degrees and
  // components of the border graph.
  std::unordered_map<int, std::vector<int>> border;
  for (const auto& [e, count] : edge_count) {
    if (count > 2) return false;
    if (count == 1) {
      border[e.first].push_back(e.second);
      border[e.second].push_back(e.first);
    }
  }
  if (border.empty()) return false;  // closed: not a disc
  for (const auto& [v, nbs] : border) {
    if (nbs.size() != 2) return false;  // pinched boundary
  }
  int loops = 0;
  std::unordered_map<int, bool> seen;
  for (const auto& [v, nbs] : border) {
    if (seen[v]) continue;
    ++loops;
    std::vector<int> stack{v};
    while (!stack.empty()) {
      const int x = stack.back();
      stack.pop_back();
      if (seen[x]) continue;
      seen[x] = true;
      for (int y : border[x]) stack.push_back(y);
    }
  }
  const long euler = static_cast<long>(chart.vertices.size()) - static_cast<long>(edge_count.size()) +
                     static_cast<long>(chart.triangles.size());
  return loops == 1 && euler == 1;
}

std::vector<std::vector<int>> SplitFaces(const std::vector<int>& faces, const FaceGraph& g) {
  RELIT_CHECK(faces.size() >= 2);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int f : faces) mean += g.centroids[f];
  mean /= static_cast<double>(faces.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int f : faces) cov += (g.centroids[f] - mean) * (g.centroids[f] - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  const Eigen::Vector3d axis = eig.eigenvectors().col(2);
  std::vector<std::pair<double, int>> projected;
  for (int f : faces) projected.push_back({(g.centroids[f] - mean).dot(axis), f});
  std::sort(projected.begin(), projected.end());
  std::unordered_map<int, int> side;
  for (std::size_t i = 0; i < projected.size(); ++i) side[projected[i].second] = i < projected.size() / 2 ? 0 : 1;
  // Face-connected pieces of each half.
  std::vector<std::vector<int>> pieces;
  std::unordered_map<int, bool> done;
  for (int f : faces) {
    if (done[f]) continue;
    pieces.emplace_back();
    std::vector<int> stack{f};
    done[f] = true;
    while (!stack.empty()) {
      const int x = stack.back();
      stack.pop_back();
      pieces.back().push_back(x);
      for (int nb : g.neighbours[x]) {
        if (nb < 0) continue;
        auto it = side.find(nb);
        if (it == side.end() || it->second != side[x] || done[nb]) continue;
        done[nb] = true;
        stack.push_back(nb);
      }
    }
  }
  return pieces;
}

ChartQuality NormaliseAndEvaluate(const render::TriangleMesh& mesh, Chart* chart) {
  ChartQuality q;
  const int n = static_cast<int>(chart->triangles.size());
  std::vector<double> signed_area(n);
  double positive = 0, negative = 0, area3d = 0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3i& t = chart->triangles[i];
    signed_area[i] = 0.5 * Cross2(chart->uv[t[1]] - chart->uv[t[0]], chart->uv[t[2]] - chart->uv[t[0]]);
    (signed_area[i] >= 0 ? positive : negative) += std::abs(signed_area[i]);
    const Eigen::Vector3i& g = mesh.triangles[chart->faces[i]];
    area3d += 0.5 * (mesh.positions[g[1]] - mesh.positions[g[0]])
                        .cross(mesh.positions[g[2]] - mesh.positions[g[0]]).cast<double>().norm();
  }
  if (negative > positive) {
    for (Eigen::Vector2d& uv : chart->uv) uv.x() = -uv.x();
    for (double& a : signed_area) a = -a;
    std::swap(positive, negative);
  }
  const double area2d = positive - negative;
  if (!(area2d > 0) || !(area3d > 0)) {
    q.degenerate = n;
    return q;
  }
  const double scale = std::sqrt(area3d / area2d);
  for (Eigen::Vector2d& uv : chart->uv) uv *= scale;
  double stretch_sum = 0;
  for (int i = 0; i < n; ++i) {
    const double a2 = signed_area[i] * scale * scale;
    if (a2 < 0) ++q.flipped;
    if (std::abs(a2) < 1e-14) {
      ++q.degenerate;
      continue;
    }
    // Sander et al. 2001: L2 stretch of the map texture -> surface.
    const Eigen::Vector3i& t = chart->triangles[i];
    const Eigen::Vector2d s1 = chart->uv[t[0]], s2 = chart->uv[t[1]], s3 = chart->uv[t[2]];
    const Eigen::Vector3i& g = mesh.triangles[chart->faces[i]];
    const Eigen::Vector3d q1 = mesh.positions[g[0]].cast<double>(), q2 = mesh.positions[g[1]].cast<double>(),
                          q3 = mesh.positions[g[2]].cast<double>();
    const double two_a = 2.0 * a2;
    const Eigen::Vector3d ss = (q1 * (s2.y() - s3.y()) + q2 * (s3.y() - s1.y()) + q3 * (s1.y() - s2.y())) / two_a;
    const Eigen::Vector3d st = (q1 * (s3.x() - s2.x()) + q2 * (s1.x() - s3.x()) + q3 * (s2.x() - s1.x())) / two_a;
    const double l2 = std::sqrt(0.5 * (ss.squaredNorm() + st.squaredNorm()));
    const double face_area = 0.5 * (q2 - q1).cross(q3 - q1).norm();
    stretch_sum += l2 * l2 * face_area;
  }
  q.stretch_l2 = std::sqrt(stretch_sum / area3d);
  // Self-overlap: the chart's UV area must equal the area it covers; sample
  // a grid and count points inside more than one triangle.
  if (q.flipped == 0) {
    Eigen::Vector2d lo = chart->uv[0], hi = chart->uv[0];
    for (const Eigen::Vector2d& uv : chart->uv) {
      lo = lo.cwiseMin(uv);
      hi = hi.cwiseMax(uv);
    }
    const double cell = std::sqrt(area3d / std::max(64.0, 16.0 * n));
    const int w = static_cast<int>((hi.x() - lo.x()) / cell) + 1, h = static_cast<int>((hi.y() - lo.y()) / cell) + 1;
    if (static_cast<long>(w) * h < 4000000) {
      std::vector<uint8_t> count(static_cast<size_t>(w) * h, 0);
      for (const Eigen::Vector3i& t : chart->triangles) {
        const Eigen::Vector2d a = chart->uv[t[0]], b = chart->uv[t[1]], c = chart->uv[t[2]];
        const Eigen::Vector2d tlo = a.cwiseMin(b).cwiseMin(c), thi = a.cwiseMax(b).cwiseMax(c);
        for (int y = std::max(0, static_cast<int>((tlo.y() - lo.y()) / cell));
             y <= std::min(h - 1, static_cast<int>((thi.y() - lo.y()) / cell)); ++y) {
          for (int x = std::max(0, static_cast<int>((tlo.x() - lo.x()) / cell));
               x <= std::min(w - 1, static_cast<int>((thi.x() - lo.x()) / cell)); ++x) {
            const Eigen::Vector2d p = lo + Eigen::Vector2d(x + 0.5, y + 0.5) * cell;
            if (Cross2(b - a, p - a) > 0 && Cross2(c - b, p - b) > 0 && Cross2(a - c, p - c) > 0) {
              if (++count[static_cast<size_t>(y) * w + x] > 1) q.overlaps = true;
            }
          }
        }
      }
    }
  }
  return q;
}

}  // namespace relit::reconstruct::atlas
