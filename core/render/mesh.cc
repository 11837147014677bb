#include "core/render/mesh.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>
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

// tinyobjloader reads a coordinate it cannot parse ("nan", "inf", "1e999",
// "x") as 0 without a word; relit reads the "v" lines itself first.
void RequireFiniteObjVertices(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.size() < 2 || line[0] != 'v' || (line[1] != ' ' && line[1] != '\t')) continue;
    const char* p = line.c_str() + 2;
    for (int k = 0; k < 3; ++k) {
      char* end = nullptr;
      errno = 0;
      const double value = std::strtod(p, &end);
      RELIT_REQUIRE(end != p && std::isfinite(value) && errno != ERANGE, "OBJ mesh ", path, ":", number,
                    ": vertex coordinate ", k + 1, " is not a finite number ('", line.substr(0, 60),
                    "'); repair or re-export the mesh");
      p = end;
    }
  }
}

TriangleMesh LoadObj(const std::string& path) {
  RequireFiniteObjVertices(path);
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
  // Every index must name an element of the file (tinyobjloader keeps
  // indices past the end, which would read beyond its arrays).
  const long vertex_count = static_cast<long>(attrib.vertices.size() / 3);
  const long uv_count = static_cast<long>(attrib.texcoords.size() / 2);
  const long normal_count = static_cast<long>(attrib.normals.size() / 3);
  for (const auto& shape : reader.GetShapes()) {
    for (size_t i = 0; i < shape.mesh.indices.size(); ++i) {
      const tinyobj::index_t& id = shape.mesh.indices[i];
      const size_t face = i / 3 + 1;
      RELIT_REQUIRE(id.vertex_index >= 0 && id.vertex_index < vertex_count, "OBJ mesh ", path, ": face ", face,
                    " of '", shape.name, "' refers to vertex ", id.vertex_index + 1, " but the file has ",
                    vertex_count, " vertices; repair or re-export the mesh");
      RELIT_REQUIRE(id.texcoord_index < uv_count, "OBJ mesh ", path, ": face ", face, " refers to texture "
                    "coordinate ", id.texcoord_index + 1, " but the file has ", uv_count, "; re-export the mesh");
      RELIT_REQUIRE(id.normal_index < normal_count, "OBJ mesh ", path, ": face ", face, " refers to normal ",
                    id.normal_index + 1, " but the file has ", normal_count, "; re-export the mesh");
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

// A NaN or infinite coordinate would move every computation it touches
// (bounds, cleanup, atlas) without an error.
void RequireFinite(const TriangleMesh& mesh, const std::string& path) {
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    RELIT_REQUIRE(mesh.positions[i].allFinite(), "mesh ", path, ": vertex ", i + 1, " has a non-finite coordinate (",
                  mesh.positions[i].x(), ", ", mesh.positions[i].y(), ", ", mesh.positions[i].z(),
                  "); repair or re-export the mesh");
  }
  for (size_t i = 0; i < mesh.normals.size(); ++i) {
    RELIT_REQUIRE(mesh.normals[i].allFinite(), "mesh ", path, ": normal ", i + 1,
                  " is not finite; repair or re-export the mesh");
  }
  for (size_t i = 0; i < mesh.uvs.size(); ++i) {
    RELIT_REQUIRE(mesh.uvs[i].allFinite(), "mesh ", path, ": texture coordinate ", i + 1,
                  " is not finite; repair or re-export the mesh");
  }
}

// OpenMesh's PLY reader loops forever on some malformed headers (e.g.
// "format binary_little_endian NaN") and allocates what the header claims:
// relit reads the header itself first and refuses anything unusual.
void RequireSanePlyHeader(const std::string& path) {
  std::error_code ec;
  const uintmax_t file_size = std::filesystem::file_size(path, ec);
  std::ifstream in(path, std::ios::binary);
  auto fail = [&](int line, const std::string& what) {
    Fail("PLY mesh ", path, ":", line, ": ", what, "; re-export the mesh (PLY 1.0, ascii or binary)");
  };
  std::string line;
  RELIT_REQUIRE(std::getline(in, line) && (line == "ply" || line == "ply\r"), "PLY mesh ", path,
                ": does not start with 'ply'; is it a PLY file?");
  static const std::vector<std::string> kTypes = {"char",   "uchar",  "short",   "ushort",  "int",    "uint",
                                                  "float",  "double", "int8",    "uint8",   "int16",  "uint16",
                                                  "int32",  "uint32", "float32", "float64"};
  auto is_type = [&](const std::string& t) { return std::find(kTypes.begin(), kTypes.end(), t) != kTypes.end(); };
  bool format = false, in_element = false, ascii = false;
  for (int number = 2; number < 1000; ++number) {
    if (!std::getline(in, line)) fail(number, "the header has no end_header line");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "end_header") {
      if (!format) fail(number, "the header has no format line");
      if (!ascii) return;
      // OpenMesh's ascii reader loops (and grows without bound) on a value
      // it cannot parse: every value must be a finite number.
      for (int body = number + 1; std::getline(in, line); ++body) {
        std::istringstream values(line);
        for (std::string token; values >> token;) {
          char* end = nullptr;
          errno = 0;
          const double value = std::strtod(token.c_str(), &end);
          if (end != token.c_str() + token.size() || !std::isfinite(value) || errno == ERANGE) {
            fail(body, "'" + token.substr(0, 30) + "' is not a finite number");
          }
        }
      }
      return;
    }
    if (keyword == "comment" || keyword == "obj_info") continue;
    std::vector<std::string> rest;
    for (std::string w; words >> w;) rest.push_back(w);
    if (keyword == "format") {
      if (format || rest.size() != 2 || rest[1] != "1.0" ||
          (rest[0] != "ascii" && rest[0] != "binary_little_endian" && rest[0] != "binary_big_endian")) {
        fail(number, "unsupported format line '" + line.substr(0, 60) + "'");
      }
      format = true;
      ascii = rest[0] == "ascii";
    } else if (keyword == "element") {
      if (rest.size() != 2 || rest[1].empty() || rest[1].size() > 12 ||
          rest[1].find_first_not_of("0123456789") != std::string::npos ||
          std::stoull(rest[1]) > static_cast<unsigned long long>(file_size)) {
        fail(number, "bad element line '" + line.substr(0, 60) + "' (a count larger than the file?)");
      }
      in_element = true;
    } else if (keyword == "property") {
      const bool ok = in_element && ((rest.size() == 2 && is_type(rest[0])) ||
                                     (rest.size() == 4 && rest[0] == "list" && is_type(rest[1]) && is_type(rest[2])));
      if (!ok) fail(number, "bad property line '" + line.substr(0, 60) + "'");
    } else {
      fail(number, "unknown header line '" + line.substr(0, 60) + "'");
    }
  }
  fail(1000, "the header is longer than 1000 lines");
}

TriangleMesh LoadPly(const std::string& path) {
  RequireSanePlyHeader(path);
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
  RequireFinite(mesh, path);
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
