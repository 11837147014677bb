// CGAL types and helpers shared by the cleanup's CGAL translation units
// (mesh_cleanup.cc, mesh_self_intersections.cc); internal to the stage.
#pragma once

#include <cstddef>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

#include "core/render/mesh.h"

namespace CGAL::Polygon_mesh_processing {}

namespace relit::reconstruct::cgal_mesh {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using Polygon = std::vector<std::size_t>;
namespace PMP = CGAL::Polygon_mesh_processing;

// Indexed soup with exactly equal positions merged; `keep` (optional, by
// face) selects the faces.
void ToSoup(const render::TriangleMesh& mesh, const std::vector<bool>* keep, std::vector<Point>* points,
            std::vector<Polygon>* polygons);

// Back to an indexed mesh, with vertex normals.
render::TriangleMesh FromMesh(const Mesh& mesh);

// Fills every hole (faired patches when `fair`, else refined ones, which
// is also the fallback); returns the number filled.
int FillHoles(Mesh& mesh, bool fair);

}  // namespace relit::reconstruct::cgal_mesh
