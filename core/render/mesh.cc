#include "core/render/mesh.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <tiny_obj_loader.h>

#include "core/error.h"

namespace relit::render {

namespace {

using OMesh = OpenMesh::TriMesh_ArrayKernelT<>;

std::string Extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  return ext;
}

TriangleMesh LoadObj(const std::string& path) {
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  RELIT_REQUIRE(reader.ParseFromFile(path, config), "cannot read OBJ mesh ", path, ": ",
                reader.Error());
  const tinyobj::attrib_t& attrib = reader.GetAttrib();
  TriangleMesh mesh;
  bool any_normals = false, any_uvs = false;
  for (const auto& shape : reader.GetShapes()) {
    for (const auto& index : shape.mesh.indices) {
      any_normals |= index.normal_index >= 0;
      any_uvs |= index.texcoord_index >= 0;
    }
  }
  // One output vertex per distinct (position, uv, normal) triple: splits seams.
  std::map<std::tuple<int, int, int>, int> remap;
  for (const auto& shape : reader.GetShapes()) {
    const auto& indices = shape.mesh.indices;
    for (size_t f = 0; f + 2 < indices.size(); f += 3) {
      Eigen::Vector3i triangle;
      for (int k = 0; k < 3; ++k) {
        const tinyobj::index_t& id = indices[f + k];
        const auto key = std::make_tuple(id.vertex_index, any_uvs ? id.texcoord_index : -1,
                                         any_normals ? id.normal_index : -1);
        auto it = remap.find(key);
        if (it == remap.end()) {
          it = remap.emplace(key, static_cast<int>(mesh.positions.size())).first;
          const float* p = &attrib.vertices[3 * id.vertex_index];
          mesh.positions.emplace_back(p[0], p[1], p[2]);
          if (any_uvs) {
            mesh.uvs.push_back(id.texcoord_index >= 0
                                   ? Eigen::Vector2f(attrib.texcoords[2 * id.texcoord_index],
                                                     attrib.texcoords[2 * id.texcoord_index + 1])
                                   : Eigen::Vector2f::Zero());
          }
          if (any_normals) {
            mesh.normals.push_back(id.normal_index >= 0
                                       ? Eigen::Vector3f(attrib.normals[3 * id.normal_index],
                                                         attrib.normals[3 * id.normal_index + 1],
                                                         attrib.normals[3 * id.normal_index + 2])
                                       : Eigen::Vector3f::Zero());
          }
        }
        triangle[k] = it->second;
      }
      mesh.triangles.push_back(triangle);
    }
  }
  return mesh;
}

TriangleMesh LoadPly(const std::string& path) {
  OMesh om;
  om.request_vertex_normals();
  om.request_vertex_texcoords2D();
  OpenMesh::IO::Options options;
  options += OpenMesh::IO::Options::VertexNormal;
  options += OpenMesh::IO::Options::VertexTexCoord;
  RELIT_REQUIRE(OpenMesh::IO::read_mesh(om, path, options), "cannot read PLY mesh ", path,
                " (not a PLY file, or non-manifold faces OpenMesh cannot load)");
  TriangleMesh mesh;
  for (const auto& v : om.vertices()) {
    const auto p = om.point(v);
    mesh.positions.emplace_back(p[0], p[1], p[2]);
    if (options.check(OpenMesh::IO::Options::VertexNormal)) {
      const auto n = om.normal(v);
      mesh.normals.emplace_back(n[0], n[1], n[2]);
    }
    if (options.check(OpenMesh::IO::Options::VertexTexCoord)) {
      const auto t = om.texcoord2D(v);
      mesh.uvs.emplace_back(t[0], t[1]);
    }
  }
  for (const auto& f : om.faces()) {
    Eigen::Vector3i triangle;
    int k = 0;
    for (const auto& v : om.fv_range(f)) {
      if (k < 3) triangle[k] = v.idx();
      ++k;
    }
    if (k == 3) mesh.triangles.push_back(triangle);
  }
  return mesh;
}

void SavePly(const std::string& path, const TriangleMesh& mesh) {
  OMesh om;
  OpenMesh::IO::Options options = OpenMesh::IO::Options::Binary;
  if (mesh.has_normals()) {
    om.request_vertex_normals();
    options += OpenMesh::IO::Options::VertexNormal;
  }
  if (mesh.has_uvs()) {
    om.request_vertex_texcoords2D();
    options += OpenMesh::IO::Options::VertexTexCoord;
  }
  std::vector<OMesh::VertexHandle> handles;
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const auto& p = mesh.positions[i];
    handles.push_back(om.add_vertex(OMesh::Point(p.x(), p.y(), p.z())));
    if (mesh.has_normals()) {
      const auto& n = mesh.normals[i];
      om.set_normal(handles.back(), OMesh::Normal(n.x(), n.y(), n.z()));
    }
    if (mesh.has_uvs()) om.set_texcoord2D(handles.back(), OMesh::TexCoord2D(mesh.uvs[i].x(), mesh.uvs[i].y()));
  }
  for (const auto& t : mesh.triangles) {
    const auto face = om.add_face(handles[t[0]], handles[t[1]], handles[t[2]]);
    RELIT_REQUIRE(face.is_valid(), "cannot write ", path,
                  ": mesh is not manifold (PLY export goes through OpenMesh); write .obj instead");
  }
  RELIT_REQUIRE(OpenMesh::IO::write_mesh(om, path, options), "cannot write mesh ", path);
}

void SaveObj(const std::string& path, const TriangleMesh& mesh) {
  std::ofstream out(path);
  RELIT_REQUIRE(out.good(), "cannot open ", path, " for writing");
  out.precision(9);
  out << "# written by relit\n";
  for (const auto& p : mesh.positions) out << "v " << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
  for (const auto& t : mesh.uvs) out << "vt " << t.x() << ' ' << t.y() << '\n';
  for (const auto& n : mesh.normals) out << "vn " << n.x() << ' ' << n.y() << ' ' << n.z() << '\n';
  for (const auto& t : mesh.triangles) {
    out << 'f';
    for (int k = 0; k < 3; ++k) {
      const int i = t[k] + 1;
      out << ' ' << i;
      if (mesh.has_uvs() || mesh.has_normals()) out << '/' << (mesh.has_uvs() ? std::to_string(i) : "");
      if (mesh.has_normals()) out << '/' << i;
    }
    out << '\n';
  }
  RELIT_REQUIRE(out.good(), "failed writing ", path);
}

}  // namespace

Eigen::AlignedBox3f TriangleMesh::Bounds() const {
  Eigen::AlignedBox3f box;
  for (const auto& p : positions) box.extend(p);
  return box;
}

void TriangleMesh::ComputeVertexNormals() {
  normals.assign(positions.size(), Eigen::Vector3f::Zero());
  for (const auto& t : triangles) {
    // Unnormalised cross product = area-weighted face normal.
    const Eigen::Vector3f n = (positions[t[1]] - positions[t[0]]).cross(positions[t[2]] - positions[t[0]]);
    for (int k = 0; k < 3; ++k) normals[t[k]] += n;
  }
  for (auto& n : normals) {
    const float len = n.norm();
    n = len > 0 ? Eigen::Vector3f(n / len) : Eigen::Vector3f::UnitZ();
  }
}

void TriangleMesh::Transform(const Eigen::Affine3f& transform) {
  const Eigen::Matrix3f normal_matrix = transform.linear().inverse().transpose();
  for (auto& p : positions) p = transform * p;
  for (auto& n : normals) n = (normal_matrix * n).normalized();
}

void TriangleMesh::Check(const std::string& what) const {
  RELIT_REQUIRE(!triangles.empty(), what, ": mesh has no triangles");
  RELIT_REQUIRE(normals.empty() || normals.size() == positions.size(), what,
                ": normal count does not match vertex count");
  RELIT_REQUIRE(uvs.empty() || uvs.size() == positions.size(), what,
                ": uv count does not match vertex count");
  const int n = static_cast<int>(positions.size());
  for (size_t f = 0; f < triangles.size(); ++f) {
    const Eigen::Vector3i& t = triangles[f];
    RELIT_REQUIRE(t.minCoeff() >= 0 && t.maxCoeff() < n, what, ": triangle ", f, " (", t[0], " ", t[1], " ", t[2],
                  ") uses a vertex out of range (", n, " vertices)");
  }
  for (size_t v = 0; v < positions.size(); ++v) {
    const Eigen::Vector3f& p = positions[v];
    RELIT_REQUIRE(p.allFinite(), what, ": vertex ", v, " is not finite (", p.x(), ", ", p.y(), ", ", p.z(), ")");
  }
}

TriangleMesh LoadMesh(const std::string& path) {
  RELIT_REQUIRE(std::filesystem::exists(path), "mesh file not found: ", path);
  const std::string ext = Extension(path);
  TriangleMesh mesh;
  if (ext == ".obj") {
    mesh = LoadObj(path);
  } else if (ext == ".ply") {
    mesh = LoadPly(path);
  } else {
    Fail("unsupported mesh format '", ext, "' for ", path, " (use .obj or .ply)");
  }
  mesh.Check(path);
  if (!mesh.has_normals()) mesh.ComputeVertexNormals();
  return mesh;
}

void SaveMesh(const std::string& path, const TriangleMesh& mesh) {
  mesh.Check(path);
  const std::filesystem::path target(path);
  if (target.has_parent_path()) std::filesystem::create_directories(target.parent_path());
  const std::string ext = Extension(path);
  // Same extension on the temporary so OpenMesh picks the right writer.
  const std::string temp = (target.parent_path() / (".tmp-" + target.filename().string())).string();
  if (ext == ".obj") {
    SaveObj(temp, mesh);
  } else if (ext == ".ply") {
    SavePly(temp, mesh);
  } else {
    Fail("unsupported mesh format '", ext, "' for ", path, " (use .obj or .ply)");
  }
  std::filesystem::rename(temp, target);
}

TriangleMesh MakeSphere(const Eigen::Vector3f& centre, float radius, int segments, int rings) {
  TriangleMesh mesh;
  for (int r = 0; r <= rings; ++r) {
    const float v = static_cast<float>(r) / rings;
    const float theta = v * 3.14159265f;
    for (int s = 0; s <= segments; ++s) {
      const float u = static_cast<float>(s) / segments;
      const float phi = u * 2.0f * 3.14159265f;
      const Eigen::Vector3f n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      mesh.positions.push_back(centre + radius * n);
      mesh.normals.push_back(n);
      mesh.uvs.emplace_back(u, 1.0f - v);
    }
  }
  const int stride = segments + 1;
  for (int r = 0; r < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      const int a = r * stride + s, b = a + 1, c = a + stride, d = c + 1;
      if (r != 0) mesh.triangles.emplace_back(a, c, b);
      if (r != rings - 1) mesh.triangles.emplace_back(b, c, d);
    }
  }
  return mesh;
}

TriangleMesh MakeQuad(const Eigen::Vector3f& centre, const Eigen::Vector3f& x_axis,
                      const Eigen::Vector3f& y_axis, float half_x, float half_y) {
  TriangleMesh mesh;
  const Eigen::Vector3f x = x_axis.normalized() * half_x, y = y_axis.normalized() * half_y;
  const Eigen::Vector3f n = x_axis.cross(y_axis).normalized();
  mesh.positions = {centre - x - y, centre + x - y, centre + x + y, centre - x + y};
  mesh.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  mesh.normals.assign(4, n);
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  return mesh;
}

}  // namespace relit::render
