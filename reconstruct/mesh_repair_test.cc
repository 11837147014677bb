// RemoveSelfIntersections on closed spheres made to intersect themselves: a
// vertex pushed through the opposite side, and folds from random vertex
// displacements (what noisy fused depth leaves in the proxy). Also the NaN
// vertices COLMAP's Poisson mesher can write.
#include <limits>
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/render/mesh.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/point_surface.h"

namespace relit::reconstruct {
namespace {

constexpr float kRadiusM = 0.05f;

// A closed, welded UV sphere about the origin: MakeSphere's seam column and
// pole rows are separate (UV) vertices at nearly equal positions.
render::TriangleMesh ClosedSphere(int segments, int rings) {
  const render::TriangleMesh uv = render::MakeSphere(Eigen::Vector3f::Zero(), kRadiusM, segments, rings);
  const int stride = segments + 1;
  render::TriangleMesh mesh;
  std::map<int, int> index;  // welded vertex of each UV vertex
  for (int r = 0; r <= rings; ++r) {
    for (int s = 0; s <= segments; ++s) {
      const int key = (r == 0) ? 0 : (r == rings) ? rings * stride : r * stride + (s == segments ? 0 : s);
      if (!index.count(key)) {
        index[key] = static_cast<int>(mesh.positions.size());
        Eigen::Vector3f p = uv.positions[key];
        if (r == 0 || r == rings) p = Eigen::Vector3f(0, 0, r == 0 ? kRadiusM : -kRadiusM);
        mesh.positions.push_back(p);
      }
      index[r * stride + s] = index[key];
    }
  }
  for (const Eigen::Vector3i& t : uv.triangles) mesh.triangles.emplace_back(index[t[0]], index[t[1]], index[t[2]]);
  return mesh;
}

void ExpectCleanSurface(const render::TriangleMesh& mesh) {
  const MeshStats stats = AnalyseMesh(mesh);
  EXPECT_TRUE(stats.closed()) << stats.ToJson().dump();
  EXPECT_TRUE(stats.manifold()) << stats.ToJson().dump();
  EXPECT_EQ(stats.components, 1);
  EXPECT_FALSE(stats.self_intersects);
  EXPECT_GT(stats.volume_m3, 0);
}

TEST(RemoveSelfIntersections, VertexPushedThroughTheOppositeSide) {
  const render::TriangleMesh sphere = ClosedSphere(32, 16);
  ExpectCleanSurface(sphere);
  // The equator vertex at +x goes to 1.25 r beyond the centre on -x: its
  // six faces become spikes piercing the other side.
  render::TriangleMesh mesh = sphere;
  int pushed = 0;
  for (int v = 0; v < static_cast<int>(mesh.positions.size()); ++v) {
    if (mesh.positions[v].x() > mesh.positions[pushed].x()) pushed = v;
  }
  mesh.positions[pushed] = Eigen::Vector3f(-1.25f * kRadiusM, 0, mesh.positions[pushed].z());
  ASSERT_TRUE(AnalyseMesh(mesh).self_intersects);
  const double chamfer_before = SymmetricChamferDistance(mesh, sphere);

  const int replaced = RemoveSelfIntersections(&mesh);
  std::cout << "replaced " << replaced << " of " << sphere.triangles.size() << " faces; stats "
            << AnalyseMesh(mesh).ToJson().dump() << "\n";
  EXPECT_GT(replaced, 6);
  EXPECT_LT(replaced, 120);
  ExpectCleanSurface(mesh);
  EXPECT_TRUE(mesh.has_normals() == false);
  // The refilled patches follow the sphere: the spikes are gone.
  const double chamfer_after = SymmetricChamferDistance(mesh, sphere);
  std::cout << "Chamfer to the sphere: " << chamfer_before * 1000 << " mm before, " << chamfer_after * 1000
            << " mm after\n";
  EXPECT_LT(chamfer_after, 0.01 * kRadiusM);
  EXPECT_LT(chamfer_after, 0.25 * chamfer_before);
}

TEST(RemoveSelfIntersections, FoldsFromVertexNoise) {
  const render::TriangleMesh sphere = ClosedSphere(64, 32);
  render::TriangleMesh mesh = sphere;
  std::mt19937 rng(7);
  const float edge_m = 2 * 3.14159265f * kRadiusM / 64;
  std::normal_distribution<float> noise(0.0f, 0.15f * edge_m);
  for (Eigen::Vector3f& p : mesh.positions) p += Eigen::Vector3f(noise(rng), noise(rng), noise(rng));
  mesh.ComputeVertexNormals();
  const MeshStats noisy = AnalyseMesh(mesh);
  ASSERT_TRUE(noisy.self_intersects);
  const double chamfer_before = SymmetricChamferDistance(mesh, sphere);

  const int replaced = RemoveSelfIntersections(&mesh);
  std::cout << "replaced " << replaced << " of " << sphere.triangles.size() << " faces; stats "
            << AnalyseMesh(mesh).ToJson().dump() << "\n";
  EXPECT_GT(replaced, 0);
  EXPECT_LT(replaced, static_cast<int>(sphere.triangles.size()) / 4);
  // Fairing alone does not untangle this much noise: some faces were cut
  // out and refilled.
  EXPECT_NE(mesh.triangles.size(), sphere.triangles.size());
  ExpectCleanSurface(mesh);
  EXPECT_EQ(mesh.normals.size(), mesh.positions.size());
  // Faired patches replace noise: no further from the sphere than before.
  const double chamfer_after = SymmetricChamferDistance(mesh, sphere);
  std::cout << "Chamfer to the sphere: " << chamfer_before * 1000 << " mm before, " << chamfer_after * 1000
            << " mm after\n";
  EXPECT_LT(chamfer_after, 1.05 * chamfer_before);
}

TEST(RemoveSelfIntersections, IntersectionFreeMeshIsLeftUnchanged) {
  render::TriangleMesh mesh = ClosedSphere(32, 16);
  mesh.ComputeVertexNormals();
  const render::TriangleMesh before = mesh;
  EXPECT_EQ(RemoveSelfIntersections(&mesh), 0);
  ASSERT_EQ(mesh.positions.size(), before.positions.size());
  ASSERT_EQ(mesh.triangles.size(), before.triangles.size());
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) EXPECT_EQ(mesh.positions[i], before.positions[i]);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) EXPECT_EQ(mesh.triangles[f], before.triangles[f]);
  EXPECT_EQ(mesh.normals.size(), before.normals.size());
}

TEST(RemoveSelfIntersections, OpenMeshIsAClearError) {
  render::TriangleMesh mesh = ClosedSphere(16, 8);
  mesh.triangles.pop_back();
  EXPECT_THROW(RemoveSelfIntersections(&mesh), relit::Error);
  render::TriangleMesh closed = ClosedSphere(16, 8);
  EXPECT_THROW(RemoveSelfIntersections(&closed, 0), relit::Error);
}

// COLMAP's Poisson mesher can write NaN vertices (3 of 240k on a `full`
// capture): they and their faces go, and the cleanup closes the holes.
TEST(DropNonFiniteVertices, ItsHolesAreFilledByTheCleanup) {
  render::TriangleMesh mesh = ClosedSphere(32, 16);
  for (Eigen::Vector3f& p : mesh.positions) p.z() += 0.1f;  // above the crop plane
  mesh.ComputeVertexNormals();
  const std::size_t vertices = mesh.positions.size();
  const Eigen::Vector3f far_vertex = mesh.positions[90];
  int fans = 0;
  for (const Eigen::Vector3i& t : mesh.triangles) fans += (t.array() == 40).any() || (t.array() == 90).any();
  mesh.positions[40] = Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  mesh.positions[90].x() = std::numeric_limits<float>::infinity();
  mesh.positions[91] = far_vertex;  // the kept vertices are re-indexed, not moved

  EXPECT_EQ(DropNonFiniteVertices(&mesh), fans);
  EXPECT_EQ(mesh.positions.size(), vertices - 2);
  EXPECT_EQ(mesh.normals.size(), vertices - 2);
  EXPECT_EQ(mesh.positions[89], far_vertex);
  EXPECT_NO_THROW(mesh.Check("mesh"));
  EXPECT_EQ(DropNonFiniteVertices(&mesh), 0);

  CleanupOptions options;
  CropRegion crop;
  CleanupReport report;
  const render::TriangleMesh clean = CleanupMesh(mesh, options, crop, &report);
  EXPECT_EQ(report.holes_filled, 2);
  const MeshStats stats = AnalyseMesh(clean);
  EXPECT_TRUE(stats.closed());
  EXPECT_TRUE(stats.manifold());
  EXPECT_EQ(stats.components, 1);
}

// A user mesh that cannot become a closed proxy (a low-poly box resting on
// the board: the crop removes every face touching z <= 2 mm; a sphere with a
// fin triangle) fails with what to change, not with internal pass names.
TEST(CleanupMesh, MeshThatCannotCloseSaysWhatToChange) {
  render::TriangleMesh box;
  for (int i = 0; i < 8; ++i) {
    box.positions.emplace_back(i & 1 ? 0.03f : -0.03f, i & 2 ? 0.03f : -0.03f, i & 4 ? 0.06f : 0.0f);
  }
  const int faces[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                            {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (const auto& f : faces) box.triangles.emplace_back(f[0], f[1], f[2]);
  render::TriangleMesh fin = ClosedSphere(16, 8);
  for (Eigen::Vector3f& p : fin.positions) p.z() += 0.1f;
  const int top = 0;  // the north pole
  fin.positions.emplace_back(0.0f, 0.0f, 0.2f);
  fin.positions.emplace_back(0.01f, 0.0f, 0.2f);
  fin.triangles.emplace_back(top, static_cast<int>(fin.positions.size()) - 2,
                             static_cast<int>(fin.positions.size()) - 1);
  for (const render::TriangleMesh* mesh : {&box, &fin}) {
    CleanupOptions options;
    CropRegion crop;
    CleanupReport report;
    try {
      const render::TriangleMesh clean = CleanupMesh(*mesh, options, crop, &report);
      ExpectCleanSurface(clean);  // a repair that closes it is fine too
    } catch (const relit::Error& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.find("CleanupMesh"), std::string::npos) << message;
      EXPECT_EQ(message.find("RemoveSelfIntersections"), std::string::npos) << message;
      EXPECT_NE(message.find("crop_margin_m"), std::string::npos) << message;
    }
  }
}

}  // namespace
}  // namespace relit::reconstruct
