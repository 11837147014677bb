// Internals of the UV atlas shared by its translation units (chart growing,
// CGAL parameterisation, packing). Not part of the stage's interface.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <unordered_set>
#include <vector>

#include <Eigen/Core>

#include "core/render/mesh.h"
#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct::atlas {

// Face adjacency over shared edges (-1 = border), normals, areas, centroids.
struct FaceGraph {
  std::vector<std::array<int, 3>> neighbours;  // across edge (k, k+1)
  std::vector<Eigen::Vector3d> normals;
  std::vector<double> areas;
  std::vector<Eigen::Vector3d> centroids;
};
FaceGraph BuildFaceGraph(const render::TriangleMesh& mesh);

// One chart: global faces, its local vertices and their UVs.
struct Chart {
  std::vector<int> faces;
  std::vector<int> vertices;                 // global vertex index per local vertex
  std::vector<Eigen::Vector3i> triangles;    // local indices, same order as faces
  std::vector<Eigen::Vector2d> uv;           // per local vertex
};
// Corners around a vertex share one local vertex only when the chart's faces
// link them across edges that are not in `cuts` (EdgeKey of global vertices).
Chart MakeChart(const render::TriangleMesh& mesh, std::vector<int> faces,
                const std::unordered_set<uint64_t>& cuts = {});

inline uint64_t EdgeKey(int a, int b) {
  return (static_cast<uint64_t>(std::min(a, b)) << 32) | static_cast<uint32_t>(std::max(a, b));
}

// Interior edges to cut so that a connected face set with a border (but
// handles or several border loops) becomes a disc: the complement of a
// breadth-first dual spanning tree, pruned of every slit ending inside.
std::unordered_set<uint64_t> CutToDisc(const render::TriangleMesh& mesh, const std::vector<int>& faces);

// Seeded region growing on the face graph; returns face lists.
std::vector<std::vector<int>> GrowCharts(const render::TriangleMesh& mesh, const FaceGraph& graph,
                                         const AtlasOptions& options);

// True when the chart is one connected topological disc (one boundary loop,
// Euler characteristic 1).
bool IsDisc(const Chart& chart);

// Splits a chart's faces in two along the principal axis of their centroids;
// the halves are then separated into face-connected pieces.
std::vector<std::vector<int>> SplitFaces(const std::vector<int>& faces, const FaceGraph& graph);

// LSCM parameterisation with CGAL (fills chart->uv); false when CGAL fails.
bool ParameterizeLscm(const render::TriangleMesh& mesh, Chart* chart);

struct ChartQuality {
  int flipped = 0;           // triangles against the majority orientation (after mirroring)
  int degenerate = 0;
  bool overlaps = false;     // two triangles cover the same point
  double stretch_l2 = 0;     // area-weighted, normalised to 1 for an isometry up to scale
};
// Mirrors the chart if most triangles are clockwise, rescales UVs to metres
// (UV area = surface area) and evaluates it.
ChartQuality NormaliseAndEvaluate(const render::TriangleMesh& mesh, Chart* chart);

// Parameterises a face set as one chart (LSCM; a single triangle is laid out
// exactly). True when it is a disc whose map has no flipped, degenerate or
// overlapping triangle and an L2 stretch <= max_stretch.
bool ParameterizeChart(const render::TriangleMesh& mesh, std::vector<int> faces, double max_stretch,
                       Chart* chart, ChartQuality* quality);

// Greedy chart merging: repeatedly takes the smallest chart and merges it
// with the neighbour it shares the longest seam with whose union still
// parameterises (ParameterizeChart with max_stretch). Returns the merge count.
int MergeCharts(const render::TriangleMesh& mesh, const FaceGraph& graph, int max_chart_faces, double max_stretch,
                std::vector<Chart>* charts);

// Packs charts (UVs in metres) into resolution^2 texels with `gutter` empty
// texels between charts. Returns false if they do not fit at any scale.
bool PackCharts(std::vector<Chart>* charts, int resolution_px, int gutter_px,
                double* texels_per_metre);

}  // namespace relit::reconstruct::atlas
