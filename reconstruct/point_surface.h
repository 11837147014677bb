// From points to a surface (the CGAL and COLMAP side of the proxy path):
// grid simplification, outlier removal and jet-fitted normals oriented
// towards the observing cameras; screened Poisson through COLMAP's
// poisson_mesher (with its density trim); CGAL advancing-front
// reconstruction for the sparse fallback; COLMAP text model points.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/render/mesh.h"
#include "reconstruct/depth_fusion.h"
#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct {

struct OrientedPoint {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
};

// Merges points closer than `spacing_m` (CGAL grid simplification), drops
// outliers (mean distance to the `neighbours` nearest above
// outlier_distance_m; 0 = 3 x CGAL's average spacing of the input), drops
// clusters (CGAL, points linked within that distance) with fewer than
// min_cluster_fraction x the largest one's points, and fits normals (CGAL
// jet fit), each flipped to face its camera.
std::vector<OrientedPoint> OrientedPointCloud(const std::vector<FusedPoint>& points, double spacing_m,
                                              int neighbours, double outlier_distance_m,
                                              double min_cluster_fraction);

// Binary PLY with x y z nx ny nz (float), as poisson_mesher reads it.
void WriteOrientedPly(const std::string& path, const std::vector<OrientedPoint>& points);
// Reads what WriteOrientedPly writes (e.g. proxy_points/fused_points.ply).
// Throws relit::Error naming the file for any other layout or a short file.
std::vector<OrientedPoint> ReadOrientedPly(const std::string& path);

// Screened Poisson surface of an oriented PLY via `colmap poisson_mesher`
// (log in `log_path`). COLMAP may exit 0 without a mesh: a missing or empty
// output is an error naming the log. Its mesher can also write NaN
// vertices (3 of 240k on a `full` capture); they and their faces are
// dropped with a warning, and the cleanup fills the holes.
render::TriangleMesh PoissonSurface(const std::string& points_ply, const std::string& mesh_ply,
                                    const std::string& log_path, const ProxyOptions& options);

// CGAL advancing-front surface over unoriented points (sparse fallback).
render::TriangleMesh AdvancingFrontSurface(const std::vector<Eigen::Vector3d>& points, const ProxyOptions& options);

// X Y Z of every point in a COLMAP text model's points3D.txt (world frame
// as calib writes it).
std::vector<Eigen::Vector3d> ReadColmapPoints(const std::string& points3d_txt);

// A PLY triangle mesh read as a polygon soup (tolerates non-manifold faces).
render::TriangleMesh ReadPlySoup(const std::string& path);

// Removes the vertices with a non-finite coordinate and every face that
// uses one (other vertices re-indexed, normals and UVs kept for the rest);
// returns the number of faces removed.
int DropNonFiniteVertices(render::TriangleMesh* mesh);

}  // namespace relit::reconstruct
