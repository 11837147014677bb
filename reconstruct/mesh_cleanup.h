// Proxy mesh cleanup with CGAL Polygon Mesh Processing: crop to the region
// above the board plane, drop small components (floaters), repair
// non-manifold input, fill holes, orient outward, isotropic remeshing and
// decimation to a target face count. Also the topological checks the stage
// and its tests report (closed, manifold, components, volume).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/render/mesh.h"
#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct {

// Crop region: a vertical cylinder about (centre_xy) of radius radius_m,
// above z = margin (world frame, board plane z = 0).
struct CropRegion {
  Eigen::Vector2d centre_xy = Eigen::Vector2d::Zero();
  double radius_m = 1.0;
};

struct CleanupReport {
  int input_faces = 0;
  int cropped_faces = 0;            // faces left after the crop
  int non_manifold_repairs = 0;     // vertices duplicated to make the input manifold
  int components_in = 0;
  int components_kept = 0;
  int holes_filled = 0;
  int handles_cut = 0;              // three-edge loops cut (CutSmallHandles)
  int self_intersection_faces_replaced = 0;  // RemoveSelfIntersections
  int output_faces = 0;
  nlohmann::json ToJson() const;
};

// Throws relit::Error when the input is empty, crops to nothing, or is
// non-manifold while options.repair_non_manifold is false.
render::TriangleMesh CleanupMesh(const render::TriangleMesh& input, const CleanupOptions& options,
                                 const CropRegion& crop, CleanupReport* report);

// Cuts every loop of three edges that is not a triangle (a tiny handle
// through the surface) and caps both sides; a loop that cuts off a part of
// at most small_part_fraction of the faces removes that part instead.
// Returns the number of loops cut (mesh_handles.cc).
int CutSmallHandles(render::TriangleMesh* mesh, double small_part_fraction);

// Removes self-intersections of a closed manifold mesh. Each round first
// fairs (PMP::fair) the vertices of the faces that intersect another (or are
// degenerate), kept if fewer intersecting pairs are left; otherwise it
// removes those faces plus one more ring of neighbours per such round, and
// every piece the removal would cut off or pinch, and fills the holes with
// faired patches (triangulate_refine_and_fair_hole). Repeats until CGAL
// finds no intersection or max_rounds run out (then a warning with the
// number of pairs left).
// A round whose result is not closed and manifold, or has more components,
// is undone. Returns the number of the input's faces replaced or reshaped
// (0 leaves the mesh untouched); the result is outward (volume > 0), normals recomputed,
// UVs dropped. Throws relit::Error when the input is not closed and manifold.
int RemoveSelfIntersections(render::TriangleMesh* mesh, int max_rounds = 10);

struct MeshStats {
  int faces = 0;
  int vertices = 0;                 // after merging equal positions
  int boundary_edges = 0;           // 0 = watertight
  int non_manifold_edges = 0;       // edges with more than two faces or inconsistent orientation
  int non_manifold_vertices = 0;
  int components = 0;
  bool self_intersects = false;
  double area_m2 = 0;
  double volume_m3 = 0;             // signed: > 0 for outward orientation
  bool closed() const { return boundary_edges == 0; }
  bool manifold() const { return non_manifold_edges == 0 && non_manifold_vertices == 0; }
  nlohmann::json ToJson() const;
};

// The mesh with exactly equal positions merged into one vertex (OBJ files
// split vertices at UV seams); triangles re-indexed, normals and UVs
// dropped. `remap` (optional) gets each input vertex's new index.
render::TriangleMesh WeldEqualPositions(const render::TriangleMesh& mesh, std::vector<int>* remap = nullptr);

// Topology of an indexed mesh; equal positions are merged first, so UV seams
// do not count as boundaries.
MeshStats AnalyseMesh(const render::TriangleMesh& mesh);

// Symmetric mean Chamfer distance in metres: the mean of the distances from
// `samples` area-uniform random points on each mesh to the other surface
// (exact point-triangle distances, CGAL AABB tree), averaged over both ways.
double SymmetricChamferDistance(const render::TriangleMesh& a, const render::TriangleMesh& b,
                                int samples = 20000, uint64_t seed = 1);

// The parts of the Chamfer distance, for benchmarks that compare point
// clouds too: area-uniform random points on a mesh; the distance from each
// point to a surface (exact point-triangle, CGAL AABB tree) or to the
// nearest of a point set (CGAL kd-tree).
std::vector<Eigen::Vector3d> SampleSurface(const render::TriangleMesh& mesh, int samples, uint64_t seed);
// With `signed_distances`, also the distance signed by the closest
// triangle's normal (> 0 in front of it: outside an outward surface).
std::vector<double> DistancesToSurface(const std::vector<Eigen::Vector3d>& points, const render::TriangleMesh& surface,
                                       std::vector<double>* signed_distances = nullptr);
std::vector<double> DistancesToPoints(const std::vector<Eigen::Vector3d>& queries,
                                      const std::vector<Eigen::Vector3d>& points);

}  // namespace relit::reconstruct
