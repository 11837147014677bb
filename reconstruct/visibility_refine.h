// Refines the cleaned proxy against the per-view depth maps it came from.
//
// Poisson extrapolates where the fused points are sparse (bulges beside the
// legs, a skirt down to the crop plane under the body), and its smoothing
// blurs what the points do say. Every depth map holds two kinds of evidence
// about a proxy vertex p seen by that view:
//  - free space: the view saw a surface *behind* p (the table under the
//    belly, the far wall of a bulge): the ray to p is empty, so p lies outside
//    the object and moves inward;
//  - support: the view saw a surface within a band around p and facing it:
//    p moves towards that surface (robust mean over the views).
// Only views in front of the surface judge a vertex. Each iteration moves
// every vertex along its normal by at most one step (shrinking linearly to
// zero over the iterations) and Taubin-smooths the mesh (no shrinkage), as
// space carving and depth-map mesh refinement do in multi-view stereo.
// The depth maps should be the multi-view consistent ones
// (FuseDepthMaps' consistent_depths): single-pair mismatches would carve real surface.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "core/render/mesh.h"
#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct {

// Depth maps (metres along the optical axis, CV_32F, 0 = unknown) with the
// undistorted cameras they were computed for; the table and board are in
// them (no crop), which is what carves the space under the object.
struct DepthEvidence {
  std::vector<std::string> names;  // frame names, for messages
  std::vector<Camera> cameras;
  std::vector<cv::Mat> depths;
  std::vector<cv::Mat> grays;  // the frames, CV_8U (the photometric refinement's input)
  bool empty() const { return depths.empty(); }
};

struct RefineReport {
  int iterations = 0;
  double step_m = 0;
  int vertices = 0;
  int carved_vertices_first = 0;   // vertices in free space at the first iteration
  int carved_vertices_last = 0;    // ... and at the last
  int supported_vertices = 0;      // vertices some view saw (at the last iteration)
  int unseen_vertices = 0;         // neither seen nor seen through (left to the smoothing)
  double mean_move_m = 0;          // mean distance each vertex moved in all
  double max_move_m = 0;
  double seconds = 0;
  int self_intersection_faces_replaced = 0;  // by the stage's RemoveSelfIntersections afterwards
  nlohmann::json ToJson() const;
};

// Moves the vertices of a closed, outward-oriented mesh (topology unchanged),
// never below z = floor_z_m (the crop plane above the board).
// A closed mesh welded at equal positions (UV seams move as one), for the
// refinements that move its vertices: they move `mesh.positions` in place,
// then Unweld() gives the input mesh with the moved positions.
struct WeldedMesh {
  explicit WeldedMesh(const render::TriangleMesh& input);
  std::vector<int> index;                 // input vertex -> welded vertex (filled first)
  render::TriangleMesh mesh;              // welded
  std::vector<Eigen::Vector3f> original;  // welded positions before any move
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  // of the original positions
  // `input` with the moved positions (normals recomputed where it had them);
  // the mean and largest move of the welded vertices.
  render::TriangleMesh Unweld(const render::TriangleMesh& input, double* mean_move_m, double* max_move_m) const;
};

// Median over the cameras of the size of one pixel at `point` (metres).
double MedianPixelFootprint(const std::vector<Camera>& cameras, const Eigen::Vector3d& point);

// Each vertex's one-ring neighbours (sorted, unique).
std::vector<std::vector<int>> VertexRings(const render::TriangleMesh& mesh);

// Clamps every position to z >= floor_z_m.
void KeepAboveFloor(double floor_z_m, std::vector<Eigen::Vector3f>* positions);

// Per-vertex offsets that follow the measured ones where they are sure and
// their neighbours elsewhere: argmin sum w (x - o)^2 + smoothness
// sum_edges (x_u - x_v)^2 + anchor x^2 (a region without measurements
// stays where it is), by `sweeps` Gauss-Seidel sweeps from the measurements
// (0 where a weight is 0).
std::vector<double> SmoothOverRings(const std::vector<double>& offsets, const std::vector<double>& weights,
                                    const std::vector<std::vector<int>>& rings, double smoothness, double anchor,
                                    int sweeps);

render::TriangleMesh RefineWithDepthMaps(const render::TriangleMesh& mesh, const DepthEvidence& evidence,
                                         const RefineOptions& options, double floor_z_m, RefineReport* report);

}  // namespace relit::reconstruct
