// Chart growing, chart topology, splitting and per-chart quality of the UV atlas.
#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <map>
#include <queue>
#include <unordered_map>
#include <unordered_set>

#include <Eigen/Eigenvalues>

#include "core/error.h"
#include "reconstruct/atlas_internal.h"

namespace relit::reconstruct::atlas {
namespace {

double Cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// True when two UV boundary segments that share no vertex touch or cross
// (uniform grid over the boundary's bounding box).
bool BoundarySelfIntersects(const Chart& chart) {
  std::map<std::pair<int, int>, int> edge_count;
  for (const Eigen::Vector3i& t : chart.triangles) {
    for (int k = 0; k < 3; ++k) edge_count[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}] += 1;
  }
  std::vector<std::pair<int, int>> edges;
  double length = 0;
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e300), hi = -lo;
  for (const auto& [e, count] : edge_count) {
    if (count != 1) continue;
    edges.push_back(e);
    const Eigen::Vector2d &a = chart.uv[e.first], &b = chart.uv[e.second];
    length += (b - a).norm();
    lo = lo.cwiseMin(a).cwiseMin(b);
    hi = hi.cwiseMax(a).cwiseMax(b);
  }
  if (edges.size() < 4) return false;
  const double cell = std::max(length / edges.size(), 1e-12);
  const int w = std::min(4096, static_cast<int>((hi.x() - lo.x()) / cell) + 1);
  const int h = std::min(4096, static_cast<int>((hi.y() - lo.y()) / cell) + 1);
  const double cx = (hi.x() - lo.x()) / w + 1e-300, cy = (hi.y() - lo.y()) / h + 1e-300;
  std::unordered_map<long, std::vector<int>> grid;
  for (int i = 0; i < static_cast<int>(edges.size()); ++i) {
    const Eigen::Vector2d &a = chart.uv[edges[i].first], &b = chart.uv[edges[i].second];
    const int x0 = std::clamp(static_cast<int>((std::min(a.x(), b.x()) - lo.x()) / cx), 0, w - 1);
    const int x1 = std::clamp(static_cast<int>((std::max(a.x(), b.x()) - lo.x()) / cx), 0, w - 1);
    const int y0 = std::clamp(static_cast<int>((std::min(a.y(), b.y()) - lo.y()) / cy), 0, h - 1);
    const int y1 = std::clamp(static_cast<int>((std::max(a.y(), b.y()) - lo.y()) / cy), 0, h - 1);
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) grid[static_cast<long>(y) * w + x].push_back(i);
    }
  }
  auto side = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r) {
    const double c = Cross2(q - p, r - p);
    return c > 0 ? 1 : (c < 0 ? -1 : 0);
  };
  for (const auto& [key, list] : grid) {
    for (std::size_t i = 0; i < list.size(); ++i) {
      for (std::size_t j = i + 1; j < list.size(); ++j) {
        const auto [a0, a1] = edges[list[i]];
        const auto [b0, b1] = edges[list[j]];
        if (a0 == b0 || a0 == b1 || a1 == b0 || a1 == b1) continue;
        const Eigen::Vector2d &p = chart.uv[a0], &q = chart.uv[a1], &r = chart.uv[b0], &s = chart.uv[b1];
        if (side(p, q, r) * side(p, q, s) <= 0 && side(r, s, p) * side(r, s, q) <= 0) {
          // Collinear but disjoint segments are not a crossing.
          if (side(p, q, r) == 0 && side(p, q, s) == 0 &&
              (std::max(p.x(), q.x()) < std::min(r.x(), s.x()) || std::max(r.x(), s.x()) < std::min(p.x(), q.x()) ||
               std::max(p.y(), q.y()) < std::min(r.y(), s.y()) || std::max(r.y(), s.y()) < std::min(p.y(), q.y()))) {
            continue;
          }
          return true;
        }
      }
    }
  }
  return false;
}

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

Chart MakeChart(const render::TriangleMesh& mesh, std::vector<int> faces, const std::unordered_set<uint64_t>& cuts) {
  Chart chart;
  chart.faces = std::move(faces);
  const int n = static_cast<int>(chart.faces.size());
  // Corners around a vertex are one local vertex only when they are linked
  // through the chart's own faces (a fan): a chart that touches itself at a
  // vertex gets two copies there and stays a disc.
  std::vector<int> parent(3 * n);
  for (int i = 0; i < 3 * n; ++i) parent[i] = i;
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::unordered_map<uint64_t, std::vector<int>> edge_corners;  // edge -> 3 i + k of its first vertex
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3i& t = mesh.triangles[chart.faces[i]];
    for (int k = 0; k < 3; ++k) edge_corners[EdgeKey(t[k], t[(k + 1) % 3])].push_back(3 * i + k);
  }
  for (const auto& [key, corners] : edge_corners) {
    if (corners.size() != 2 || cuts.count(key)) continue;
    const int i = corners[0] / 3, k = corners[0] % 3, j = corners[1] / 3, l = corners[1] % 3;
    const Eigen::Vector3i &ti = mesh.triangles[chart.faces[i]], &tj = mesh.triangles[chart.faces[j]];
    // Join the corners at each end of the shared edge.
    for (int a = 0; a < 2; ++a) {
      const int ka = (k + a) % 3;
      for (int b = 0; b < 2; ++b) {
        const int lb = (l + b) % 3;
        if (ti[ka] == tj[lb]) parent[find(3 * i + ka)] = find(3 * j + lb);
      }
    }
  }
  std::unordered_map<int, int> local;  // corner root -> local vertex
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3i t;
    for (int k = 0; k < 3; ++k) {
      auto [it, inserted] = local.emplace(find(3 * i + k), static_cast<int>(chart.vertices.size()));
      if (inserted) chart.vertices.push_back(mesh.triangles[chart.faces[i]][k]);
      t[k] = it->second;
    }
    chart.triangles.push_back(t);
  }
  chart.uv.assign(chart.vertices.size(), Eigen::Vector2d::Zero());
  return chart;
}

std::unordered_set<uint64_t> CutToDisc(const render::TriangleMesh& mesh, const std::vector<int>& faces) {
  // Interior edges -> the two faces (chart-local) on them.
  std::unordered_map<uint64_t, std::vector<int>> edge_faces;
  for (int i = 0; i < static_cast<int>(faces.size()); ++i) {
    const Eigen::Vector3i& t = mesh.triangles[faces[i]];
    for (int k = 0; k < 3; ++k) edge_faces[EdgeKey(t[k], t[(k + 1) % 3])].push_back(i);
  }
  std::unordered_map<int, std::vector<std::pair<int, uint64_t>>> adjacent;  // face -> (face, edge)
  std::unordered_set<int> border;
  for (const auto& [key, list] : edge_faces) {
    if (list.size() == 2) {
      adjacent[list[0]].push_back({list[1], key});
      adjacent[list[1]].push_back({list[0], key});
    } else {
      border.insert(static_cast<int>(key >> 32));
      border.insert(static_cast<int>(key & 0xffffffffu));
    }
  }
  if (border.empty()) return {};  // closed: no cut makes it a disc with this scheme
  // Breadth-first dual spanning tree from the face nearest the centroid:
  // cutting every other interior edge leaves a disc.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int f : faces) centre += mesh.positions[mesh.triangles[f][0]].cast<double>();
  centre /= static_cast<double>(faces.size());
  int root = 0;
  double best = 1e300;
  for (int i = 0; i < static_cast<int>(faces.size()); ++i) {
    const double d = (mesh.positions[mesh.triangles[faces[i]][0]].cast<double>() - centre).squaredNorm();
    if (d < best) best = d, root = i;
  }
  std::vector<bool> reached(faces.size(), false);
  std::unordered_set<uint64_t> tree;
  std::deque<int> queue{root};
  reached[root] = true;
  while (!queue.empty()) {
    const int i = queue.front();
    queue.pop_front();
    for (const auto& [j, key] : adjacent[i]) {
      if (reached[j]) continue;
      reached[j] = true;
      tree.insert(key);
      queue.push_back(j);
    }
  }
  std::unordered_set<uint64_t> cuts;
  std::unordered_map<int, std::vector<uint64_t>> vertex_cuts;
  for (const auto& [key, list] : edge_faces) {
    if (list.size() != 2 || tree.count(key)) continue;
    cuts.insert(key);
    vertex_cuts[static_cast<int>(key >> 32)].push_back(key);
    vertex_cuts[static_cast<int>(key & 0xffffffffu)].push_back(key);
  }
  // Glue back cut edges that end at an interior vertex (zipping the slits up
  // from their tips) until only paths around handles and to the border stay.
  std::vector<int> tips;
  for (const auto& [v, list] : vertex_cuts) {
    if (list.size() == 1 && !border.count(v)) tips.push_back(v);
  }
  while (!tips.empty()) {
    const int v = tips.back();
    tips.pop_back();
    std::vector<uint64_t>& list = vertex_cuts[v];
    uint64_t key = 0;
    bool found = false;
    for (uint64_t k : list) {
      if (cuts.count(k)) key = k, found = true;
    }
    if (!found) continue;
    int live = 0;
    for (uint64_t k : list) live += cuts.count(k) > 0;
    if (live != 1) continue;
    cuts.erase(key);
    const int a = static_cast<int>(key >> 32), b = static_cast<int>(key & 0xffffffffu);
    const int other = a == v ? b : a;
    if (border.count(other)) continue;
    int remaining = 0;
    for (uint64_t k : vertex_cuts[other]) remaining += cuts.count(k) > 0;
    if (remaining == 1) tips.push_back(other);
  }
  return cuts;
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
  // Self-overlap: with every triangle positively oriented the map covers each
  // point inside its boundary exactly once iff the boundary is a simple
  // closed curve (degree argument), so test boundary edges for crossings.
  if (q.flipped == 0) q.overlaps = BoundarySelfIntersects(*chart);
  return q;
}

}  // namespace relit::reconstruct::atlas
