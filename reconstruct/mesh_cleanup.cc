// The cleanup itself and the mesh checks and distances (CGAL); the
// self-intersection repair is in mesh_self_intersections.cc.
#include "reconstruct/mesh_cleanup.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <vector>

#include <random>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Orthogonal_k_neighbor_search.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/boost/graph/helpers.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/manifoldness.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Polygon_mesh_processing/repair.h>
#include <CGAL/Polygon_mesh_processing/repair_degeneracies.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/tangential_relaxation.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <CGAL/Search_traits_3.h>
#include <spdlog/spdlog.h>

#include "core/error.h"
#include "reconstruct/cgal_mesh.h"

namespace relit::reconstruct {
namespace cgal_mesh {

void ToSoup(const render::TriangleMesh& mesh, const std::vector<bool>* keep,
            std::vector<Point>* points, std::vector<Polygon>* polygons) {
  const render::TriangleMesh welded = WeldEqualPositions(mesh);
  for (const Eigen::Vector3f& p : welded.positions) points->emplace_back(p.x(), p.y(), p.z());
  for (std::size_t f = 0; f < welded.triangles.size(); ++f) {
    if (keep && !(*keep)[f]) continue;
    const Eigen::Vector3i& t = welded.triangles[f];
    polygons->push_back({static_cast<std::size_t>(t[0]), static_cast<std::size_t>(t[1]),
                         static_cast<std::size_t>(t[2])});
  }
}

render::TriangleMesh FromMesh(const Mesh& mesh) {
  render::TriangleMesh out;
  std::map<Mesh::Vertex_index, int> index;
  for (Mesh::Vertex_index v : mesh.vertices()) {
    index[v] = static_cast<int>(out.positions.size());
    const Point& p = mesh.point(v);
    out.positions.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                               static_cast<float>(p.z()));
  }
  for (Mesh::Face_index f : mesh.faces()) {
    Eigen::Vector3i t;
    int k = 0;
    for (Mesh::Vertex_index v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) {
      if (k < 3) t[k] = index[v];
      ++k;
    }
    RELIT_CHECK(k == 3);
    out.triangles.push_back(t);
  }
  out.ComputeVertexNormals();
  return out;
}

int FillHoles(Mesh& mesh, bool fair) {
  std::vector<Mesh::Halfedge_index> borders;
  PMP::extract_boundary_cycles(mesh, std::back_inserter(borders));
  int filled = 0;
  for (Mesh::Halfedge_index h : borders) {
    if (!mesh.is_border(h)) continue;  // closed by an earlier fill
    std::vector<Mesh::Face_index> faces;
    std::vector<Mesh::Vertex_index> vertices;
    bool ok = false;
    if (fair) {
      ok = std::get<0>(PMP::triangulate_refine_and_fair_hole(
          mesh, h, std::back_inserter(faces), std::back_inserter(vertices)));
    }
    if (!ok && mesh.is_border(h)) {
      faces.clear();
      vertices.clear();
      PMP::triangulate_and_refine_hole(mesh, h, std::back_inserter(faces),
                                       std::back_inserter(vertices));
      ok = !faces.empty();
    }
    if (ok) ++filled;
  }
  return filled;
}

}  // namespace cgal_mesh

using namespace cgal_mesh;

namespace {

namespace SMS = CGAL::Surface_mesh_simplification;


// Drops components whose area is below `fraction` of the largest one.
void DropSmallComponents(Mesh& mesh, double fraction, CleanupReport* report) {
  auto fccmap = mesh.add_property_map<Mesh::Face_index, std::size_t>("f:cc", 0).first;
  const std::size_t count = PMP::connected_components(mesh, fccmap);
  std::vector<double> area(count, 0.0);
  for (Mesh::Face_index f : mesh.faces()) area[fccmap[f]] += PMP::face_area(f, mesh);
  const double largest = *std::max_element(area.begin(), area.end());
  std::vector<std::size_t> keep;
  for (std::size_t c = 0; c < count; ++c) {
    if (area[c] >= fraction * largest) keep.push_back(c);
  }
  report->components_in = static_cast<int>(count);
  report->components_kept = static_cast<int>(keep.size());
  PMP::keep_connected_components(mesh, keep, fccmap);
  mesh.remove_property_map(fccmap);
  mesh.collect_garbage();
}

// Hole fills and remeshing may bulge below the crop plane: flatten onto it.
void ClampAbovePlane(Mesh& mesh, double z_min) {
  for (Mesh::Vertex_index v : mesh.vertices()) {
    const Point& p = mesh.point(v);
    if (p.z() < z_min) mesh.point(v) = Point(p.x(), p.y(), z_min);
  }
}

}  // namespace

render::TriangleMesh WeldEqualPositions(const render::TriangleMesh& mesh, std::vector<int>* remap) {
  render::TriangleMesh out;
  std::map<std::array<float, 3>, int> index;
  std::vector<int> new_index(mesh.positions.size());
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    const Eigen::Vector3f& p = mesh.positions[i];
    const auto [it, inserted] =
        index.emplace(std::array<float, 3>{p.x(), p.y(), p.z()}, static_cast<int>(out.positions.size()));
    if (inserted) out.positions.push_back(p);
    new_index[i] = it->second;
  }
  for (const Eigen::Vector3i& t : mesh.triangles) {
    out.triangles.emplace_back(new_index[t[0]], new_index[t[1]], new_index[t[2]]);
  }
  if (remap) *remap = std::move(new_index);
  return out;
}

nlohmann::json CleanupReport::ToJson() const {
  return {{"input_faces", input_faces},           {"cropped_faces", cropped_faces},
          {"non_manifold_repairs", non_manifold_repairs}, {"components_in", components_in},
          {"components_kept", components_kept},   {"holes_filled", holes_filled},
          {"handles_cut", handles_cut},
          {"self_intersection_faces_replaced", self_intersection_faces_replaced},
          {"output_faces", output_faces}};
}

render::TriangleMesh CleanupMesh(const render::TriangleMesh& input, const CleanupOptions& options,
                                 const CropRegion& crop, CleanupReport* report) {
  input.Check("input mesh");
  RELIT_REQUIRE(!input.triangles.empty(), "reconstruct: the input mesh has no triangles");
  report->input_faces = static_cast<int>(input.triangles.size());

  // 1. Crop: above the board plane, inside the cylinder.
  std::vector<bool> keep(input.triangles.size(), true);
  int kept = 0;
  for (std::size_t f = 0; f < input.triangles.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d p = input.positions[input.triangles[f][k]].cast<double>();
      if (p.z() <= options.crop_margin_m || (p.head<2>() - crop.centre_xy).norm() > crop.radius_m) {
        keep[f] = false;
      }
    }
    kept += keep[f] ? 1 : 0;
  }
  report->cropped_faces = kept;
  RELIT_REQUIRE(kept > 0, "reconstruct: the mesh crops to nothing: no triangle lies above z = ",
                options.crop_margin_m, " m within ", crop.radius_m, " m of (", crop.centre_xy.x(),
                ", ", crop.centre_xy.y(), "); is it in the board (world) frame, in metres?");

  // 2. Soup -> manifold, consistently oriented polygon mesh.
  std::vector<Point> points;
  std::vector<Polygon> polygons;
  ToSoup(input, &keep, &points, &polygons);
  PMP::repair_polygon_soup(points, polygons);
  const bool manifold_soup = PMP::orient_polygon_soup(points, polygons);
  const std::size_t points_before = points.size();
  if (!manifold_soup) {
    RELIT_REQUIRE(options.repair_non_manifold,
                  "reconstruct: the input mesh is not manifold (edges shared by more than two "
                  "triangles or inconsistent orientation); set cleanup.repair_non_manifold: true "
                  "to repair it");
  }
  Mesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  report->non_manifold_repairs = static_cast<int>(points.size() - points_before);
  report->non_manifold_repairs += static_cast<int>(PMP::duplicate_non_manifold_vertices(mesh));
  RELIT_REQUIRE(mesh.number_of_faces() > 0, "reconstruct: no valid triangles left after repair");

  // 3. Floaters and small pieces.
  DropSmallComponents(mesh, options.min_component_fraction, report);

  // 4. Holes (the crop opens the object where it touched the board).
  report->holes_filled = FillHoles(mesh, options.fair_holes);
  ClampAbovePlane(mesh, options.crop_margin_m);
  // Clamping flattens faces that reached below the plane; the remeshing and
  // its relaxation below must not start from degenerate faces.
  PMP::remove_degenerate_faces(mesh);
  mesh.collect_garbage();
  PMP::duplicate_non_manifold_vertices(mesh);
  if (CGAL::is_closed(mesh)) PMP::orient(mesh, CGAL::parameters::outward_orientation(true));

  // 5. Isotropic remeshing slightly finer than the target, then decimation.
  const double area = PMP::area(mesh);
  const double target_edge_m =
      std::sqrt(4.0 * area / (std::sqrt(3.0) * options.target_faces)) * 0.85;
  // One iteration at a time, with the tangential relaxation run on its own
  // after dropping degenerate faces: CGAL 5.5's relaxation inside the
  // remeshing dereferences a null halfedge (segfault) when a flip has left a
  // vertex with only degenerate faces, as on folded advancing-front surfaces.
  for (int i = 0; i < options.remesh_iterations; ++i) {
    PMP::isotropic_remeshing(faces(mesh), target_edge_m, mesh,
                             CGAL::parameters::number_of_iterations(1).number_of_relaxation_steps(0));
    mesh.collect_garbage();
    PMP::remove_degenerate_faces(mesh);
    mesh.collect_garbage();
    PMP::tangential_relaxation(vertices(mesh), mesh);
  }
  if (static_cast<int>(mesh.number_of_faces()) > options.target_faces) {
    const std::size_t target_edges =
        static_cast<std::size_t>(mesh.number_of_edges()) * options.target_faces / mesh.number_of_faces();
    SMS::Count_stop_predicate<Mesh> stop(target_edges);
    SMS::edge_collapse(mesh, stop);
    mesh.collect_garbage();
  }
  PMP::remove_isolated_vertices(mesh);
  mesh.collect_garbage();
  ClampAbovePlane(mesh, options.crop_margin_m);
  if (CGAL::is_closed(mesh)) {
    PMP::orient(mesh, CGAL::parameters::outward_orientation(true));
    // orient() judges by the extreme vertex, which a fold (e.g. in an
    // advancing-front surface) can mislead; the signed volume cannot be.
    if (PMP::volume(mesh) < 0) PMP::reverse_face_orientations(mesh);
  }
  render::TriangleMesh out = FromMesh(mesh);
  if (options.cut_small_handles) report->handles_cut = CutSmallHandles(&out, options.cut_off_fraction);
  if (options.remove_self_intersections) {
    // The self-intersection pass needs a closed surface; say what to change
    // in the user's terms rather than the pass's.
    std::vector<Point> check_points;
    std::vector<Polygon> check_polygons;
    ToSoup(out, nullptr, &check_points, &check_polygons);
    const bool closed_manifold = PMP::orient_polygon_soup(check_points, check_polygons);
    Mesh check;
    PMP::polygon_soup_to_polygon_mesh(check_points, check_polygons, check);
    RELIT_REQUIRE(closed_manifold && !check_polygons.empty() && CGAL::is_closed(check),
                  "reconstruct: the proxy is not a closed surface after cleanup (", report->input_faces,
                  " faces in, ", report->cropped_faces, " kept above z = ", options.crop_margin_m,
                  " m, ", out.triangles.size(), " after repair). A mesh given with --mesh must be closed "
                  "(watertight) and manifold; faces at or below z = ", options.crop_margin_m,
                  " m are cropped, so a low-poly object resting on the board loses its sides: lift it, "
                  "subdivide it, or set reconstruct cleanup.crop_margin_m: 0; or turn this pass off with "
                  "cleanup.remove_self_intersections: false");
    report->self_intersection_faces_replaced = RemoveSelfIntersections(&out, options.self_intersection_rounds);
  }
  report->output_faces = static_cast<int>(out.triangles.size());
  spdlog::info("cleanup: {} -> {} faces after crop, {} of {} components kept, {} holes filled, {} small handles cut, "
               "{} faces",
               report->input_faces, report->cropped_faces, report->components_kept, report->components_in,
               report->holes_filled, report->handles_cut, report->output_faces);
  return out;
}

// The JSON keys are the members' names.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(MeshStats, faces, vertices, boundary_edges, non_manifold_edges,
                                   non_manifold_vertices, components, self_intersects, area_m2, volume_m3)

nlohmann::json MeshStats::ToJson() const {
  nlohmann::json json = *this;
  json["closed"] = closed();
  json["manifold"] = manifold();
  return json;
}

MeshStats AnalyseMesh(const render::TriangleMesh& input) {
  MeshStats stats;
  stats.faces = static_cast<int>(input.triangles.size());
  std::vector<Point> points;
  std::vector<Polygon> polygons;
  ToSoup(input, nullptr, &points, &polygons);
  stats.vertices = static_cast<int>(points.size());
  // Directed edge counts: a manifold, consistently oriented surface uses
  // every undirected edge at most once in each direction.
  std::map<std::pair<std::size_t, std::size_t>, std::array<int, 2>> edges;
  for (const Polygon& p : polygons) {
    for (int k = 0; k < 3; ++k) {
      const std::size_t a = p[k], b = p[(k + 1) % 3];
      edges[{std::min(a, b), std::max(a, b)}][a < b ? 0 : 1] += 1;
    }
  }
  for (const auto& [edge, count] : edges) {
    if (count[0] > 1 || count[1] > 1) {
      ++stats.non_manifold_edges;
    } else if (count[0] + count[1] == 1) {
      ++stats.boundary_edges;
    }
  }
  if (stats.non_manifold_edges > 0 || polygons.empty()) return stats;
  Mesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  std::vector<Mesh::Halfedge_index> pinched;
  PMP::non_manifold_vertices(mesh, std::back_inserter(pinched));
  stats.non_manifold_vertices = static_cast<int>(pinched.size());
  auto fccmap = mesh.add_property_map<Mesh::Face_index, std::size_t>("f:cc", 0).first;
  stats.components = static_cast<int>(PMP::connected_components(mesh, fccmap));
  stats.self_intersects = PMP::does_self_intersect(mesh);
  stats.area_m2 = PMP::area(mesh);
  if (CGAL::is_closed(mesh)) stats.volume_m3 = PMP::volume(mesh);
  return stats;
}

std::vector<Eigen::Vector3d> SampleSurface(const render::TriangleMesh& mesh, int samples, uint64_t seed) {
  RELIT_REQUIRE(!mesh.triangles.empty(), "surface samples of an empty mesh");
  std::vector<double> cumulative;
  double total = 0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    total += 0.5 * (mesh.positions[t[1]] - mesh.positions[t[0]])
                       .cross(mesh.positions[t[2]] - mesh.positions[t[0]]).cast<double>().norm();
    cumulative.push_back(total);
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<Eigen::Vector3d> out;
  out.reserve(samples);
  for (int i = 0; i < samples; ++i) {
    const auto it = std::lower_bound(cumulative.begin(), cumulative.end(), uniform(rng) * total);
    const Eigen::Vector3i& t = mesh.triangles[std::min<std::size_t>(it - cumulative.begin(), mesh.triangles.size() - 1)];
    double u = uniform(rng), v = uniform(rng);
    if (u + v > 1) {
      u = 1 - u;
      v = 1 - v;
    }
    out.push_back(mesh.positions[t[0]].cast<double>() +
                  u * (mesh.positions[t[1]] - mesh.positions[t[0]]).cast<double>() +
                  v * (mesh.positions[t[2]] - mesh.positions[t[0]]).cast<double>());
  }
  return out;
}

std::vector<double> DistancesToSurface(const std::vector<Eigen::Vector3d>& points, const render::TriangleMesh& surface,
                                       std::vector<double>* signed_distances) {
  using Triangle = Kernel::Triangle_3;
  using Iterator = std::vector<Triangle>::const_iterator;
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, CGAL::AABB_triangle_primitive<Kernel, Iterator>>>;
  RELIT_REQUIRE(!surface.triangles.empty(), "distances to an empty mesh");
  auto point = [](const Eigen::Vector3f& p) { return Point(p.x(), p.y(), p.z()); };
  std::vector<Triangle> triangles;
  for (const Eigen::Vector3i& t : surface.triangles) {
    triangles.emplace_back(point(surface.positions[t[0]]), point(surface.positions[t[1]]),
                           point(surface.positions[t[2]]));
  }
  Tree tree(triangles.cbegin(), triangles.cend());
  tree.accelerate_distance_queries();
  std::vector<double> out;
  out.reserve(points.size());
  if (signed_distances) signed_distances->clear();
  for (const Eigen::Vector3d& p : points) {
    const Point q(p.x(), p.y(), p.z());
    if (!signed_distances) {
      out.push_back(std::sqrt(tree.squared_distance(q)));
      continue;
    }
    const auto [closest, triangle] = tree.closest_point_and_primitive(q);
    const double distance = std::sqrt(CGAL::squared_distance(q, closest));
    out.push_back(distance);
    const Kernel::Vector_3 normal = CGAL::normal(triangle->vertex(0), triangle->vertex(1), triangle->vertex(2));
    signed_distances->push_back((q - closest) * normal >= 0 ? distance : -distance);
  }
  return out;
}

std::vector<double> DistancesToPoints(const std::vector<Eigen::Vector3d>& queries,
                                      const std::vector<Eigen::Vector3d>& points) {
  using Traits = CGAL::Search_traits_3<Kernel>;
  using Search = CGAL::Orthogonal_k_neighbor_search<Traits>;
  RELIT_REQUIRE(!points.empty(), "distances to an empty point set");
  std::vector<Point> cgal_points;
  cgal_points.reserve(points.size());
  for (const Eigen::Vector3d& p : points) cgal_points.emplace_back(p.x(), p.y(), p.z());
  const Search::Tree tree(cgal_points.begin(), cgal_points.end());
  std::vector<double> out;
  out.reserve(queries.size());
  for (const Eigen::Vector3d& q : queries) {
    const Search search(tree, Point(q.x(), q.y(), q.z()), 1);
    out.push_back(std::sqrt(search.begin()->second));
  }
  return out;
}

namespace {

double Mean(const std::vector<double>& values) {
  double sum = 0;
  for (double v : values) sum += v;
  return values.empty() ? 0 : sum / values.size();
}

}  // namespace

double SymmetricChamferDistance(const render::TriangleMesh& a, const render::TriangleMesh& b, int samples,
                                uint64_t seed) {
  RELIT_REQUIRE(!a.triangles.empty() && !b.triangles.empty(), "Chamfer distance of an empty mesh");
  return 0.5 * (Mean(DistancesToSurface(SampleSurface(a, samples, seed), b)) +
                Mean(DistancesToSurface(SampleSurface(b, samples, seed + 1), a)));
}

}  // namespace relit::reconstruct
