// CGAL translation unit of the proxy path (CGAL compiles slowly: keep it here).
#include "reconstruct/point_surface.h"

#include <algorithm>
#include <array>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <tuple>

#include <CGAL/Advancing_front_surface_reconstruction.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/cluster_point_set.h>
#include <CGAL/compute_average_spacing.h>
#include <CGAL/IO/polygon_soup_io.h>
#include <CGAL/grid_simplify_point_set.h>
#include <CGAL/jet_estimate_normals.h>
#include <CGAL/property_map.h>
#include <CGAL/remove_outliers.h>
#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/shell.h"

namespace relit::reconstruct {
namespace {

namespace fs = std::filesystem;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Vector = Kernel::Vector_3;
// position, normal, direction to the observing camera
using PointTuple = std::tuple<Point, Vector, Vector>;
using PositionMap = CGAL::Nth_of_tuple_property_map<0, PointTuple>;
using NormalMap = CGAL::Nth_of_tuple_property_map<1, PointTuple>;

// Cluster index of each point in a side vector (cluster_point_set writes
// through const references, which the tuple maps do not allow).
struct ClusterMap {
  using key_type = PointTuple;
  using value_type = int;
  using reference = int;
  using category = boost::read_write_property_map_tag;
  const PointTuple* base;
  std::vector<int>* clusters;
  friend int get(const ClusterMap& m, const PointTuple& p) { return (*m.clusters)[&p - m.base]; }
  friend void put(const ClusterMap& m, const PointTuple& p, int c) { (*m.clusters)[&p - m.base] = c; }
};

#ifdef CGAL_LINKED_WITH_TBB
using Concurrency = CGAL::Parallel_tag;
#else
using Concurrency = CGAL::Sequential_tag;
#endif

}  // namespace

std::vector<OrientedPoint> OrientedPointCloud(const std::vector<FusedPoint>& input, double spacing_m,
                                              int neighbours, double outlier_distance_m,
                                              double min_cluster_fraction) {
  std::vector<PointTuple> points;
  points.reserve(input.size());
  for (const FusedPoint& p : input) {
    points.emplace_back(Point(p.position_m.x(), p.position_m.y(), p.position_m.z()), Vector(0, 0, 0),
                        Vector(p.to_camera.x(), p.to_camera.y(), p.to_camera.z()));
  }
  const auto params = CGAL::parameters::point_map(PositionMap()).normal_map(NormalMap());
  points.erase(CGAL::grid_simplify_point_set(points, spacing_m, params), points.end());
  if (static_cast<int>(points.size()) > neighbours) {
    const double distance = outlier_distance_m > 0
                                ? outlier_distance_m
                                : 3.0 * CGAL::compute_average_spacing<Concurrency>(points, neighbours, params);
    points.erase(CGAL::remove_outliers<Concurrency>(points, neighbours,
                                                    params.threshold_percent(100.0).threshold_distance(distance)),
                 points.end());
    // Clusters much smaller than the largest are floaters (board edges, table).
    std::vector<int> cluster(points.size(), -1);
    const std::size_t clusters =
        points.empty() ? 0
                       : CGAL::cluster_point_set(points, ClusterMap{points.data(), &cluster},
                                                 params.neighbor_radius(distance));
    std::vector<std::size_t> sizes(clusters, 0);
    for (const int c : cluster) {
      if (c >= 0) ++sizes[c];
    }
    const std::size_t largest = clusters ? *std::max_element(sizes.begin(), sizes.end()) : 0;
    std::vector<PointTuple> kept;
    for (size_t i = 0; i < points.size(); ++i) {
      if (cluster[i] >= 0 && sizes[cluster[i]] >= min_cluster_fraction * largest) kept.push_back(points[i]);
    }
    points.swap(kept);
  }
  if (static_cast<int>(points.size()) <= neighbours) return {};
  CGAL::jet_estimate_normals<Concurrency>(points, neighbours, params);
  std::vector<OrientedPoint> out;
  out.reserve(points.size());
  for (const PointTuple& t : points) {
    OrientedPoint o;
    const Point& p = std::get<0>(t);
    const Vector& n = std::get<1>(t);
    o.position_m = Eigen::Vector3d(p.x(), p.y(), p.z());
    o.normal = Eigen::Vector3d(n.x(), n.y(), n.z()).normalized();
    if (n * std::get<2>(t) < 0) o.normal = -o.normal;  // face the camera that saw it
    if (o.normal.allFinite()) out.push_back(o);
  }
  return out;
}

void WriteOrientedPly(const std::string& path, const std::vector<OrientedPoint>& points) {
  std::ofstream out(path, std::ios::binary);
  RELIT_REQUIRE(out, "cannot write ", path);
  out << "ply\nformat binary_little_endian 1.0\nelement vertex " << points.size()
      << "\nproperty float x\nproperty float y\nproperty float z\n"
         "property float nx\nproperty float ny\nproperty float nz\nend_header\n";
  for (const OrientedPoint& p : points) {
    const std::array<float, 6> v = {float(p.position_m.x()), float(p.position_m.y()), float(p.position_m.z()),
                                    float(p.normal.x()),     float(p.normal.y()),     float(p.normal.z())};
    out.write(reinterpret_cast<const char*>(v.data()), sizeof(v));
  }
  RELIT_REQUIRE(out.good(), "error writing ", path);
}

std::vector<OrientedPoint> ReadOrientedPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  RELIT_REQUIRE(in, "cannot open ", path);
  std::string line;
  std::size_t count = 0;
  int floats = 0;
  bool binary = false;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream words(line);
    std::string word, kind;
    words >> word;
    if (word == "format") binary = line.find("binary_little_endian") != std::string::npos;
    if (word == "element" && (words >> kind) && kind == "vertex") words >> count;
    if (word == "property") {
      words >> kind;
      RELIT_REQUIRE(kind == "float", path, ": expected float properties, got ", line);
      ++floats;
    }
  }
  RELIT_REQUIRE(binary && floats == 6 && count > 0, path, " is not a binary oriented point PLY (x y z nx ny nz)");
  std::array<float, 6> row;
  std::vector<OrientedPoint> points;
  points.reserve(count);
  for (std::size_t i = 0; i < count && in.read(reinterpret_cast<char*>(row.data()), sizeof(row)); ++i) {
    points.push_back({Eigen::Vector3d(row[0], row[1], row[2]), Eigen::Vector3d(row[3], row[4], row[5])});
  }
  RELIT_REQUIRE(points.size() == count, path, " is truncated: ", points.size(), " of ", count, " points");
  return points;
}

render::TriangleMesh PoissonSurface(const std::string& points_ply, const std::string& mesh_ply,
                                    const std::string& log_path, const ProxyOptions& options) {
  std::error_code ignored;
  fs::remove(mesh_ply, ignored);
  std::ostringstream command;
  // The points carry no colour (color 0, else COLMAP rejects the file). Its
  // OpenMP threads spin while waiting, which on a loaded machine costs more
  // than they gain: one thread unless proxy.threads says otherwise.
  command << "OMP_WAIT_POLICY=PASSIVE " << ShellQuote(options.colmap) << " poisson_mesher --input_path "
          << ShellQuote(points_ply) << " --output_path " << ShellQuote(mesh_ply) << " --PoissonMeshing.depth "
          << options.poisson_depth << " --PoissonMeshing.trim " << options.poisson_trim
          << " --PoissonMeshing.color 0 --PoissonMeshing.num_threads " << std::max(1, options.threads) << " > "
          << ShellQuote(log_path) << " 2>&1";
  spdlog::debug("running {}", command.str());
  const int status = std::system(command.str().c_str());
  RELIT_REQUIRE(status == 0, "reconstruct: COLMAP poisson_mesher failed (exit status ", status, "); see ", log_path,
                " (is '", options.colmap, "' COLMAP? set proxy.colmap)");
  // COLMAP reports some failures only in its log and still exits 0.
  RELIT_REQUIRE(fs::exists(mesh_ply) && fs::file_size(mesh_ply) > 0, "reconstruct: COLMAP poisson_mesher wrote no mesh ",
                mesh_ply, "; see ", log_path);
  render::TriangleMesh mesh = ReadPlySoup(mesh_ply);
  const size_t vertices = mesh.positions.size();
  const int dropped_faces = DropNonFiniteVertices(&mesh);
  if (dropped_faces > 0) {
    spdlog::warn("COLMAP poisson_mesher wrote {} non-finite vertices in {}; they and their {} faces are dropped, "
                 "the cleanup fills the holes",
                 vertices - mesh.positions.size(), fs::path(mesh_ply).filename().string(), dropped_faces);
  }
  RELIT_REQUIRE(!mesh.triangles.empty(), "reconstruct: COLMAP poisson_mesher produced an empty mesh (", mesh_ply,
                "); see ", log_path, "; try a lower proxy.poisson_trim");
  return mesh;
}

render::TriangleMesh AdvancingFrontSurface(const std::vector<Eigen::Vector3d>& input, const ProxyOptions& options) {
  std::vector<Point> points;
  points.reserve(input.size());
  for (const Eigen::Vector3d& p : input) points.emplace_back(p.x(), p.y(), p.z());
  std::vector<std::array<std::size_t, 3>> facets;
  CGAL::advancing_front_surface_reconstruction(points.begin(), points.end(), std::back_inserter(facets),
                                               options.advancing_front_radius_ratio, options.advancing_front_beta);
  render::TriangleMesh mesh;
  for (const Point& p : points) mesh.positions.emplace_back(float(p.x()), float(p.y()), float(p.z()));
  for (const auto& f : facets) mesh.triangles.emplace_back(int(f[0]), int(f[1]), int(f[2]));
  return mesh;
}

std::vector<Eigen::Vector3d> ReadColmapPoints(const std::string& points3d_txt) {
  std::ifstream in(points3d_txt);
  RELIT_REQUIRE(in, "cannot read the COLMAP points ", points3d_txt);
  std::vector<Eigen::Vector3d> points;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    long id = 0;
    Eigen::Vector3d p;
    RELIT_REQUIRE(static_cast<bool>(fields >> id >> p.x() >> p.y() >> p.z()), points3d_txt, ": cannot parse '",
                  line, "'");
    points.push_back(p);
  }
  return points;
}

render::TriangleMesh ReadPlySoup(const std::string& path) {
  std::vector<Point> points;
  std::vector<std::vector<std::size_t>> polygons;
  RELIT_REQUIRE(CGAL::IO::read_polygon_soup(path, points, polygons), "cannot read the PLY mesh ", path);
  render::TriangleMesh mesh;
  for (const Point& p : points) mesh.positions.emplace_back(float(p.x()), float(p.y()), float(p.z()));
  for (const auto& polygon : polygons) {
    for (size_t k = 1; k + 1 < polygon.size(); ++k) {  // fan-triangulate (Poisson writes triangles)
      mesh.triangles.emplace_back(int(polygon[0]), int(polygon[k]), int(polygon[k + 1]));
    }
  }
  return mesh;
}

int DropNonFiniteVertices(render::TriangleMesh* mesh) {
  const size_t n = mesh->positions.size();
  std::vector<int> remap(n, -1);
  int kept = 0;
  for (size_t v = 0; v < n; ++v) {
    if (mesh->positions[v].allFinite()) remap[v] = kept++;
  }
  if (kept == static_cast<int>(n)) return 0;
  auto compact = [&](auto& values) {
    if (values.size() != n) return;
    for (size_t v = 0; v < n; ++v) {
      if (remap[v] >= 0) values[remap[v]] = values[v];
    }
    values.resize(kept);
  };
  compact(mesh->positions);
  compact(mesh->normals);
  compact(mesh->uvs);
  const size_t faces = mesh->triangles.size();
  std::vector<Eigen::Vector3i> triangles;
  for (const Eigen::Vector3i& t : mesh->triangles) {
    RELIT_REQUIRE(t.minCoeff() >= 0 && t.maxCoeff() < static_cast<int>(n), "mesh face (", t.transpose(),
                  ") uses a vertex out of range (", n, " vertices)");
    const Eigen::Vector3i r(remap[t[0]], remap[t[1]], remap[t[2]]);
    if (r.minCoeff() >= 0) triangles.push_back(r);
  }
  mesh->triangles = std::move(triangles);
  return static_cast<int>(faces - mesh->triangles.size());
}

}  // namespace relit::reconstruct
