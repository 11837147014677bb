// Triangle meshes: loading (OBJ via tinyobjloader, PLY via OpenMesh) and saving.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace relit::render {

// Indexed triangle mesh with optional per-vertex normals and UVs. OBJ files
// with UV seams are split on load so each vertex carries one UV and normal.
struct TriangleMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;  // empty or one per position
  std::vector<Eigen::Vector2f> uvs;      // empty or one per position
  std::vector<Eigen::Vector3i> triangles;

  bool has_normals() const { return !normals.empty(); }
  bool has_uvs() const { return !uvs.empty(); }
  Eigen::AlignedBox3f Bounds() const;
  // Area-weighted vertex normals (replaces existing ones).
  void ComputeVertexNormals();
  // Applies world_from_object to positions and the inverse transpose to normals.
  void Transform(const Eigen::Affine3f& transform);
  // Throws relit::Error when indices are out of range or arrays mismatch.
  void Check(const std::string& what) const;
};

// Loads .obj or .ply; throws relit::Error naming the file on failure.
TriangleMesh LoadMesh(const std::string& path);
// Writes .obj (with vt/vn when present) or .ply.
void SaveMesh(const std::string& path, const TriangleMesh& mesh);

// Simple shapes for tests and scenes (unit UVs, outward normals).
TriangleMesh MakeSphere(const Eigen::Vector3f& centre, float radius, int segments = 64, int rings = 32);
// Quad centred at `centre` spanning +-half_x along x_axis, +-half_y along y_axis,
// facing normal = x_axis x y_axis.
TriangleMesh MakeQuad(const Eigen::Vector3f& centre, const Eigen::Vector3f& x_axis,
                      const Eigen::Vector3f& y_axis, float half_x, float half_y);

}  // namespace relit::render
