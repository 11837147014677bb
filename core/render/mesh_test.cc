#include "core/render/mesh.h"

#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "core/test_dir.h"

namespace relit::render {
namespace {

std::string TempPath(const std::string& name) { return test_support::TempPathIn("relit_mesh_test", name); }

TEST(Mesh, ObjWithSeamSplitsVertices) {
  const std::string path = TempPath("seam.obj");
  std::ofstream(path) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                         "vt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvt 0.5 0.5\n"
                         "f 1/1 2/2 3/3\nf 2/5 4/4 3/3\n";
  const TriangleMesh mesh = LoadMesh(path);
  EXPECT_EQ(mesh.triangles.size(), 2u);
  EXPECT_EQ(mesh.positions.size(), 5u);  // vertex 2 carries two UVs
  ASSERT_TRUE(mesh.has_uvs());
  ASSERT_TRUE(mesh.has_normals());  // computed on load
  EXPECT_NEAR(mesh.normals[0].z(), 1.0f, 1e-6f);
}

TEST(Mesh, ObjAndPlyRoundTrip) {
  const TriangleMesh sphere = MakeSphere({0.1f, 0.2f, 0.3f}, 0.5f, 16, 8);
  for (const char* name : {"sphere.obj", "sphere.ply"}) {
    const std::string path = TempPath(name);
    SaveMesh(path, sphere);
    const TriangleMesh back = LoadMesh(path);
    ASSERT_EQ(back.triangles.size(), sphere.triangles.size()) << name;
    const auto a = sphere.Bounds(), b = back.Bounds();
    EXPECT_LT((a.min() - b.min()).norm(), 1e-5f) << name;
    EXPECT_LT((a.max() - b.max()).norm(), 1e-5f) << name;
    EXPECT_TRUE(back.has_uvs()) << name;
  }
}

TEST(Mesh, SphereNormalsPointOutward) {
  const TriangleMesh sphere = MakeSphere(Eigen::Vector3f::Zero(), 1.0f, 24, 12);
  for (const auto& t : sphere.triangles) {
    const Eigen::Vector3f& a = sphere.positions[t[0]];
    const Eigen::Vector3f n = (sphere.positions[t[1]] - a).cross(sphere.positions[t[2]] - a);
    EXPECT_GT(n.dot(a + sphere.positions[t[1]] + sphere.positions[t[2]]), 0);
  }
}

TEST(Mesh, BadInputIsClearError) {
  EXPECT_THROW(LoadMesh(TempPath("missing.obj")), std::runtime_error);
  const std::string path = TempPath("bad.stl");
  std::ofstream(path) << "solid x\n";
  EXPECT_THROW(LoadMesh(path), std::runtime_error);
  const std::string empty = TempPath("empty.obj");
  std::ofstream(empty) << "# nothing\n";
  EXPECT_THROW(LoadMesh(empty), std::runtime_error);
}

// A proxy mesh file with a coordinate that is not a number or an index past
// the end is refused with the file and the line or face, not read as 0 or
// past the arrays (docs/refusals.md).
TEST(Mesh, BadCoordinatesAndIndicesInTheFileAreRefused) {
  auto message = [](const std::string& name, const std::string& text) {
    const std::string path = TempPath(name);
    std::ofstream(path) << text;
    try {
      LoadMesh(path);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string tetra = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";
  EXPECT_EQ(message("ok.obj", tetra), "no error");
  for (const char* bad : {"nan", "inf", "-inf", "1e999", "x"}) {
    std::string text = tetra;
    text.replace(text.find("v 1 0 0"), 7, std::string("v 1 ") + bad + " 0");
    const std::string e = message("nan.obj", text);
    EXPECT_NE(e.find("nan.obj:2: vertex coordinate 2 is not a finite number"), std::string::npos) << bad << ": " << e;
  }
  const std::string e = message("index.obj", tetra + "f 1 2 9\n");
  EXPECT_NE(e.find("index.obj"), std::string::npos) << e;
  EXPECT_NE(e.find("9"), std::string::npos) << e;
  EXPECT_NE(message("nan.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                               "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                               "end_header\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n")
                .find("nan.ply:11: 'nan' is not a finite number"),
            std::string::npos);  // OpenMesh would loop on it
  // A header OpenMesh would loop on, and counts larger than the file.
  EXPECT_NE(message("hang.ply", "ply\nformat binary_little_endian NaN\nelement vertex 3\nend_header\n")
                .find("unsupported format line"),
            std::string::npos);
  EXPECT_NE(message("huge.ply", "ply\nformat ascii 1.0\nelement vertex 99999999999\nproperty float x\nend_header\n")
                .find("bad element line"),
            std::string::npos);
}

// Check names the mesh, the element and what is wrong with it.
TEST(Mesh, CheckNamesTheBadVertexOrTriangle) {
  auto message = [](const TriangleMesh& mesh) {
    try {
      mesh.Check("proxy.obj");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  TriangleMesh mesh = MakeSphere(Eigen::Vector3f::Zero(), 0.1f, 8, 4);
  EXPECT_EQ(message(mesh), "no error");
  mesh.positions[3].y() = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(message(mesh).find("proxy.obj: vertex 3 is not finite"), std::string::npos) << message(mesh);
  mesh = MakeSphere(Eigen::Vector3f::Zero(), 0.1f, 8, 4);
  const int n = static_cast<int>(mesh.positions.size());
  mesh.triangles[5][1] = n;
  EXPECT_NE(message(mesh).find("proxy.obj: triangle 5"), std::string::npos) << message(mesh);
  EXPECT_NE(message(mesh).find("out of range (" + std::to_string(n) + " vertices)"), std::string::npos)
      << message(mesh);
}

}  // namespace
}  // namespace relit::render
