// Chart merging after growth. On noisy fused surfaces (depth noise, folds)
// growing on face normals stops at every bump, leaving a thousand tiny charts
// whose gutters eat the atlas. Merging adjacent charts while the union still
// parameterises cleanly (the criterion that matters) removes most seams, as
// production atlas tools do after growing.
#include <algorithm>
#include <cmath>
#include <queue>
#include <set>
#include <unordered_map>

#include "reconstruct/atlas_internal.h"

namespace relit::reconstruct::atlas {
namespace {

struct Slot {
  Chart chart;
  double area = 0;
  bool alive = true;
};

double FaceArea(const FaceGraph& g, const std::vector<int>& faces) {
  double area = 0;
  for (int f : faces) area += g.areas[f];
  return area;
}

// Faces of the charts enclosed by the union of slots s and t (the union is an
// annulus when the two share a seam in several pieces): connected parts of
// the complement that stay under `limit` faces. Empty when there are none.
std::vector<int> EnclosedFaces(const FaceGraph& g, const std::vector<int>& owner, int s, int t,
                               const std::vector<int>& faces, int limit) {
  std::unordered_map<int, bool> outside;  // complement faces visited -> part of a too large part
  std::vector<int> enclosed;
  for (int f : faces) {
    for (int start : g.neighbours[f]) {
      if (start < 0 || owner[start] == s || owner[start] == t || outside.count(start)) continue;
      std::vector<int> part{start}, stack{start};
      outside[start] = false;
      bool large = false;
      while (!stack.empty() && !large) {
        const int x = stack.back();
        stack.pop_back();
        for (int nb : g.neighbours[x]) {
          if (nb < 0 || owner[nb] == s || owner[nb] == t) continue;
          const auto it = outside.find(nb);
          if (it != outside.end()) {
            large = large || it->second;
            continue;
          }
          outside[nb] = false;
          part.push_back(nb);
          stack.push_back(nb);
        }
        large = large || static_cast<int>(part.size()) > limit;
      }
      for (int x : part) outside[x] = large;
      if (!large) enclosed.insert(enclosed.end(), part.begin(), part.end());
    }
  }
  return enclosed;
}

}  // namespace

int MergeCharts(const render::TriangleMesh& mesh, const FaceGraph& g, int max_chart_faces, double max_stretch,
                std::vector<Chart>* charts) {
  std::vector<Slot> slots;
  std::vector<int> owner(mesh.triangles.size(), -1);
  using Entry = std::pair<double, int>;  // area, slot
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  for (Chart& chart : *charts) {
    Slot slot;
    slot.area = FaceArea(g, chart.faces);
    for (int f : chart.faces) owner[f] = static_cast<int>(slots.size());
    slot.chart = std::move(chart);
    queue.push({slot.area, static_cast<int>(slots.size())});
    slots.push_back(std::move(slot));
  }
  // Slots are never reused, so a failed pair stays failed.
  std::set<std::pair<int, int>> failed;
  int merges = 0;
  while (!queue.empty()) {
    const int s = queue.top().second;
    queue.pop();
    if (!slots[s].alive) continue;
    // Seam length shared with every neighbouring chart.
    std::unordered_map<int, double> seam;
    for (int f : slots[s].chart.faces) {
      const Eigen::Vector3i& t = mesh.triangles[f];
      for (int k = 0; k < 3; ++k) {
        const int nb = g.neighbours[f][k];
        if (nb < 0 || owner[nb] == s) continue;
        seam[owner[nb]] += (mesh.positions[t[(k + 1) % 3]] - mesh.positions[t[k]]).norm();
      }
    }
    std::vector<std::pair<double, int>> candidates;
    for (const auto& [other, length] : seam) candidates.push_back({-length, other});
    std::sort(candidates.begin(), candidates.end());
    for (const auto& [neg_length, other] : candidates) {
      const std::pair<int, int> key(std::min(s, other), std::max(s, other));
      if (failed.count(key)) continue;
      const std::vector<int>& a = slots[s].chart.faces;
      const std::vector<int>& b = slots[other].chart.faces;
      if (static_cast<int>(a.size() + b.size()) > max_chart_faces) continue;
      std::vector<int> faces = a;
      faces.insert(faces.end(), b.begin(), b.end());
      // Charts the union encloses join it, or it could not be a disc.
      const std::vector<int> enclosed =
          EnclosedFaces(g, owner, s, other, faces, max_chart_faces - static_cast<int>(faces.size()));
      faces.insert(faces.end(), enclosed.begin(), enclosed.end());
      Chart merged;
      ChartQuality quality;
      if (!ParameterizeChart(mesh, std::move(faces), max_stretch, &merged, &quality)) {
        failed.insert(key);
        continue;
      }
      slots[s].alive = slots[other].alive = false;
      for (int f : enclosed) slots[owner[f]].alive = false;
      Slot slot;
      slot.area = FaceArea(g, merged.faces);
      slot.chart = std::move(merged);
      const int id = static_cast<int>(slots.size());
      for (int f : slot.chart.faces) owner[f] = id;
      queue.push({slot.area, id});
      slots.push_back(std::move(slot));
      ++merges;
      break;
    }
  }
  charts->clear();
  for (Slot& slot : slots) {
    if (slot.alive) charts->push_back(std::move(slot.chart));
  }
  return merges;
}

}  // namespace relit::reconstruct::atlas
