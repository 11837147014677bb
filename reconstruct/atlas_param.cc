// LSCM chart parameterisation with CGAL (the atlas' only CGAL translation unit).
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_parameterization/LSCM_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/parameterize.h>

#include "reconstruct/atlas_internal.h"

namespace relit::reconstruct::atlas {

bool ParameterizeLscm(const render::TriangleMesh& mesh, Chart* chart) {
  using Kernel = CGAL::Simple_cartesian<double>;
  using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
  using Vertex = Mesh::Vertex_index;
  namespace SMP = CGAL::Surface_mesh_parameterization;

  Mesh sm;
  std::vector<Vertex> vertices;
  vertices.reserve(chart->vertices.size());
  for (int v : chart->vertices) {
    const Eigen::Vector3f& p = mesh.positions[v];
    vertices.push_back(sm.add_vertex(Kernel::Point_3(p.x(), p.y(), p.z())));
  }
  for (const Eigen::Vector3i& t : chart->triangles) {
    if (sm.add_face(vertices[t[0]], vertices[t[1]], vertices[t[2]]) == Mesh::null_face()) return false;
  }
  const Mesh::Halfedge_index border = CGAL::Polygon_mesh_processing::longest_border(sm).first;
  if (border == Mesh::null_halfedge()) return false;
  auto uv_map = sm.add_property_map<Vertex, Kernel::Point_2>("v:uv").first;
  const SMP::Error_code err = SMP::parameterize(sm, SMP::LSCM_parameterizer_3<Mesh>(), border, uv_map);
  if (err != SMP::OK) return false;
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const Kernel::Point_2& uv = uv_map[vertices[i]];
    chart->uv[i] = Eigen::Vector2d(uv.x(), uv.y());
    if (!std::isfinite(uv.x()) || !std::isfinite(uv.y())) return false;
  }
  return true;
}

}  // namespace relit::reconstruct::atlas
