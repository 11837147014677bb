// Topological noise removal: screened Poisson on noisy fused points leaves
// tiny tunnels through the surface (the calibrated demo proxy has genus 142),
// which after remeshing show up as three edges closing a loop that is not a
// triangle. Each such loop is cut open and both sides capped with a triangle
// (Guskov and Wood 2001 do this for general short loops), which removes a
// handle; a loop that cuts off a small piece (a bubble on a neck) drops it.
#include <algorithm>
#include <array>
#include <unordered_set>
#include <vector>

#include "reconstruct/mesh_cleanup.h"

namespace relit::reconstruct {
namespace {

struct Topology {
  render::TriangleMesh* mesh;
  std::vector<std::vector<int>> vertex_faces;
  std::vector<bool> removed;
  std::vector<int> moved;  // loop vertices and their copies

  bool HasVertex(int f, int v) const {
    const Eigen::Vector3i& t = mesh->triangles[f];
    return t[0] == v || t[1] == v || t[2] == v;
  }
  std::vector<int> EdgeFaces(int a, int b) const {
    std::vector<int> out;
    for (int f : vertex_faces[a]) {
      if (!removed[f] && HasVertex(f, b)) out.push_back(f);
    }
    return out;
  }
  // Faces around v connected to `start` across edges (v, x), x not in `stop`.
  std::vector<int> Fan(int v, int start, const std::array<int, 3>& stop) const {
    std::vector<int> fan{start}, stack{start};
    std::unordered_set<int> seen{start};
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      for (int k = 0; k < 3; ++k) {
        const int x = mesh->triangles[f][k];
        if (x == v || x == stop[0] || x == stop[1] || x == stop[2]) continue;
        for (int g : EdgeFaces(v, x)) {
          if (seen.insert(g).second) {
            fan.push_back(g);
            stack.push_back(g);
          }
        }
      }
    }
    return fan;
  }
  // Faces reachable from `start` without crossing the loop's edges.
  std::vector<int> Side(int start, const std::array<int, 3>& loop, std::size_t limit) const {
    std::vector<int> side{start}, stack{start};
    std::unordered_set<int> seen{start};
    auto on_loop = [&](int x) { return x == loop[0] || x == loop[1] || x == loop[2]; };
    while (!stack.empty() && side.size() <= limit) {
      const int f = stack.back();
      stack.pop_back();
      const Eigen::Vector3i& t = mesh->triangles[f];
      for (int k = 0; k < 3; ++k) {
        const int a = t[k], b = t[(k + 1) % 3];
        if (on_loop(a) && on_loop(b)) continue;
        for (int g : EdgeFaces(a, b)) {
          if (seen.insert(g).second) {
            side.push_back(g);
            stack.push_back(g);
          }
        }
      }
    }
    return side;
  }
  void AddFace(const Eigen::Vector3i& t) {
    const int f = static_cast<int>(mesh->triangles.size());
    mesh->triangles.push_back(t);
    removed.push_back(false);
    for (int k = 0; k < 3; ++k) vertex_faces[t[k]].push_back(f);
  }
};

// The cap closing the side of `face`: the loop (a, b, c) oriented against
// face's use of edge (a, b).
Eigen::Vector3i Cap(const Eigen::Vector3i& face, int a, int b, int c) {
  for (int k = 0; k < 3; ++k) {
    if (face[k] == a && face[(k + 1) % 3] == b) return {b, a, c};
  }
  return {a, b, c};
}

// Cuts along the non-triangle loop (a, b, c); false when it is not a clean
// manifold loop or separates two large parts.
bool CutLoop(Topology* topo, int a, int b, int c, std::size_t small_part) {
  const std::array<int, 3> loop{a, b, c};
  for (int k = 0; k < 3; ++k) {
    if (topo->EdgeFaces(loop[k], loop[(k + 1) % 3]).size() != 2) return false;
  }
  for (int f : topo->vertex_faces[a]) {
    if (!topo->removed[f] && topo->HasVertex(f, b) && topo->HasVertex(f, c)) return false;  // a real triangle
  }
  const std::vector<int> ab = topo->EdgeFaces(a, b);
  const std::size_t faces = topo->mesh->triangles.size();
  const std::vector<int> side1 = topo->Side(ab[0], loop, faces);
  const bool separating = std::find(side1.begin(), side1.end(), ab[1]) == side1.end();
  if (separating) {
    // Drop the small side (a bubble on a neck) and cap the other.
    const std::vector<int> side2 = topo->Side(ab[1], loop, small_part);
    const bool first_small = side1.size() <= small_part;
    if (!first_small && side2.size() > small_part) return false;
    const std::vector<int>& drop = first_small ? side1 : side2;
    const int keep = first_small ? ab[1] : ab[0];
    for (int f : drop) topo->removed[f] = true;
    topo->AddFace(Cap(topo->mesh->triangles[keep], a, b, c));
    return true;
  }
  // Side 1 at each loop vertex: the fan holding ab[0] at a and b, at c the
  // fan holding the (c, a) face that a's fan holds. Each fan must hold one
  // face of each of its two loop edges, consistently.
  const std::vector<int> ca = topo->EdgeFaces(c, a), bc = topo->EdgeFaces(b, c);
  auto holds = [](const std::vector<int>& fan, int f) { return std::find(fan.begin(), fan.end(), f) != fan.end(); };
  std::array<std::vector<int>, 3> fans;
  fans[0] = topo->Fan(a, ab[0], loop);
  fans[1] = topo->Fan(b, ab[0], loop);
  if (holds(fans[0], ca[0]) == holds(fans[0], ca[1])) return false;
  fans[2] = topo->Fan(c, holds(fans[0], ca[0]) ? ca[0] : ca[1], loop);
  if (holds(fans[1], bc[0]) == holds(fans[1], bc[1])) return false;
  if (holds(fans[1], bc[0]) != holds(fans[2], bc[0]) || holds(fans[1], bc[1]) != holds(fans[2], bc[1])) return false;
  if (holds(fans[0], ab[1]) || holds(fans[1], ab[1])) return false;
  std::array<int, 3> copy;
  topo->moved.insert(topo->moved.end(), loop.begin(), loop.end());
  for (int k = 0; k < 3; ++k) {
    const int v = loop[k];
    copy[k] = static_cast<int>(topo->mesh->positions.size());
    topo->mesh->positions.push_back(topo->mesh->positions[v]);
    topo->vertex_faces.emplace_back();
    topo->moved.push_back(copy[k]);
    std::vector<int> keep;
    for (int f : topo->vertex_faces[v]) {
      if (topo->removed[f]) continue;
      if (holds(fans[k], f)) {
        keep.push_back(f);
      } else {
        for (int j = 0; j < 3; ++j) {
          if (topo->mesh->triangles[f][j] == v) topo->mesh->triangles[f][j] = copy[k];
        }
        topo->vertex_faces[copy[k]].push_back(f);
      }
    }
    topo->vertex_faces[v] = keep;
  }
  topo->AddFace(Cap(topo->mesh->triangles[ab[0]], a, b, c));
  topo->AddFace(Cap(topo->mesh->triangles[ab[1]], copy[0], copy[1], copy[2]));
  return true;
}

}  // namespace

int CutSmallHandles(render::TriangleMesh* mesh, double small_part_fraction) {
  Topology topo{mesh, std::vector<std::vector<int>>(mesh->positions.size()),
                std::vector<bool>(mesh->triangles.size(), false), {}};
  for (std::size_t f = 0; f < mesh->triangles.size(); ++f) {
    for (int k = 0; k < 3; ++k) topo.vertex_faces[mesh->triangles[f][k]].push_back(static_cast<int>(f));
  }
  const std::size_t small_part = static_cast<std::size_t>(small_part_fraction * mesh->triangles.size());
  int cuts = 0;
  for (bool changed = true; changed;) {
    changed = false;
    for (int a = 0; a < static_cast<int>(mesh->positions.size()); ++a) {
      for (bool cut = true; cut;) {
        cut = false;
        // Neighbours of a, then every pair of them that is joined by an edge.
        std::vector<int> ring;
        for (int f : topo.vertex_faces[a]) {
          if (topo.removed[f]) continue;
          for (int k = 0; k < 3; ++k) {
            if (mesh->triangles[f][k] > a) ring.push_back(mesh->triangles[f][k]);
          }
        }
        std::sort(ring.begin(), ring.end());
        ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
        for (std::size_t i = 0; i < ring.size() && !cut; ++i) {
          for (std::size_t j = i + 1; j < ring.size() && !cut; ++j) {
            if (topo.EdgeFaces(ring[i], ring[j]).empty()) continue;
            cut = CutLoop(&topo, a, ring[i], ring[j], small_part);
          }
        }
        if (cut) ++cuts, changed = true;
      }
    }
  }
  // A loop's vertex and its copy start at the same point; a tenth of a
  // Laplacian step on each (towards its own side) separates the two caps.
  std::vector<Eigen::Vector3f> next(topo.moved.size());
  for (std::size_t i = 0; i < topo.moved.size(); ++i) {
    const int v = topo.moved[i];
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    int count = 0;
    for (int f : topo.vertex_faces[v]) {
      if (topo.removed[f]) continue;
      for (int k = 0; k < 3; ++k) {
        if (mesh->triangles[f][k] != v) sum += mesh->positions[mesh->triangles[f][k]], ++count;
      }
    }
    next[i] = count > 0 ? Eigen::Vector3f(0.9f * mesh->positions[v] + 0.1f * sum / count) : mesh->positions[v];
  }
  for (std::size_t i = 0; i < topo.moved.size(); ++i) mesh->positions[topo.moved[i]] = next[i];
  // Compact: drop removed faces and unused vertices.
  std::vector<Eigen::Vector3i> triangles;
  for (std::size_t f = 0; f < mesh->triangles.size(); ++f) {
    if (!topo.removed[f]) triangles.push_back(mesh->triangles[f]);
  }
  std::vector<int> index(mesh->positions.size(), -1);
  std::vector<Eigen::Vector3f> positions;
  for (Eigen::Vector3i& t : triangles) {
    for (int k = 0; k < 3; ++k) {
      if (index[t[k]] < 0) {
        index[t[k]] = static_cast<int>(positions.size());
        positions.push_back(mesh->positions[t[k]]);
      }
      t[k] = index[t[k]];
    }
  }
  mesh->positions = std::move(positions);
  mesh->triangles = std::move(triangles);
  mesh->uvs.clear();
  if (mesh->has_normals()) mesh->ComputeVertexNormals();
  return cuts;
}

}  // namespace relit::reconstruct
