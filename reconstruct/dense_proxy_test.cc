// The dense CPU proxy path (StereoSGBM depth maps, multi-view consistency,
// screened Poisson) and the sparse fallback on a synthetic workspace (the
// tiny spot capture rendered with pinhole cameras from the true poses),
// checked against the ground-truth mesh.
#include <filesystem>
#include <iostream>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/workspace.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/reconstruct.h"
#include "reconstruct/test_workspace.h"

namespace relit::reconstruct {
namespace {

namespace fs = std::filesystem;

// Phone V frames (matted) and geometry-pass frames (the proxy's input).
constexpr int kViewFrames = 2;
constexpr int kGeometryFrames = 20;

const testing::TestWorkspace& Workspace() {
  return testing::SharedTestWorkspace("reconstruct_dense_ws", kViewFrames, 16, 0.003, kGeometryFrames);
}

// Chamfer, topology and the board check of the proxy the stage wrote.
void CheckProxy(const testing::TestWorkspace& ws, const std::string& label, double max_chamfer_fraction) {
  const ProxyFile proxy = ReadProxyFile((fs::path(ws.dir) / "reconstruct" / "proxy.json").string());
  const render::TriangleMesh mesh = render::LoadMesh((fs::path(ws.dir) / proxy.mesh).string());
  const MeshStats stats = AnalyseMesh(mesh);
  EXPECT_TRUE(stats.closed()) << stats.boundary_edges << " boundary edges";
  EXPECT_TRUE(stats.manifold());
  EXPECT_EQ(stats.components, 1);
  EXPECT_GT(stats.volume_m3, 0);
  const double diagonal = ws.truth_mesh.Bounds().diagonal().norm();
  const double chamfer = SymmetricChamferDistance(mesh, ws.truth_mesh, 20000);
  std::cout << label << " proxy vs GT: Chamfer " << 1000 * chamfer << " mm = " << 100 * chamfer / diagonal
            << "% of the GT bbox diagonal (" << diagonal << " m), " << stats.faces << " faces, self-intersecting "
            << stats.self_intersects << "\n";
  EXPECT_LT(chamfer / diagonal, max_chamfer_fraction);
  // No board: every vertex is above the plane, and those near it stand
  // within the object's footprint (near a GT vertex low on the object).
  std::vector<Eigen::Vector2f> footprint;
  for (const Eigen::Vector3f& p : ws.truth_mesh.positions) {
    if (p.z() < 0.01f) footprint.push_back(p.head<2>());
  }
  ASSERT_FALSE(footprint.empty());
  int outside = 0;
  for (const Eigen::Vector3f& p : mesh.positions) {
    ASSERT_GT(p.z(), 0.0f);
    if (p.z() > 0.005f) continue;
    float nearest = 1e9f;
    for (const Eigen::Vector2f& q : footprint) nearest = std::min(nearest, (p.head<2>() - q).norm());
    if (nearest > 0.01f) ++outside;
  }
  EXPECT_EQ(outside, 0) << "vertices on the board outside the object's footprint";
}

TEST(DenseProxy, StereoPoissonAndSparseProxiesMatchTheTruth) {
  const testing::TestWorkspace& ws = Workspace();
  ReconstructOptions options;
  options.workspace = ws.dir;
  options.max_matte_frames = 2;
  options.proxy.sparse_fallback = false;  // the dense path itself must deliver
  const ReconstructSummary summary = RunReconstructImpl(options);
  EXPECT_EQ(summary.mattes, 2);
  const nlohmann::json report =
      ReadJsonFile((fs::path(ws.dir) / "reconstruct" / "reconstruct_report.json").string(), "reconstruct_report", 1);
  EXPECT_EQ(report["proxy"]["method"], "dense");
  std::cout << "fused points " << report["proxy"]["fused_points"] << ", oriented " << report["proxy"]["oriented_points"]
            << ", raw Poisson faces " << report["proxy"]["raw_faces"] << "\n";
  CheckProxy(ws, "dense", 0.05);
  EXPECT_TRUE(fs::exists(fs::path(ws.dir) / "reconstruct" / "proxy_points" / "fused_points.ply"));

  // The sparse fallback on the same frames (one render per test process):
  // no COLMAP model here, so advancing front over the depth points.
  options.proxy.method = "sparse";
  RunReconstructImpl(options);
  const nlohmann::json sparse_report =
      ReadJsonFile((fs::path(ws.dir) / "reconstruct" / "reconstruct_report.json").string(), "reconstruct_report", 1);
  EXPECT_EQ(sparse_report["proxy"]["method"], "sparse");
  EXPECT_EQ(sparse_report["proxy"]["sparse_source"], "depth points");
  CheckProxy(ws, "sparse", 0.05);
}

TEST(DenseProxy, BlackFramesAreAClearError) {
  const std::string dir = ::testing::TempDir() + "/reconstruct_black_ws_" + std::to_string(getpid());
  const testing::TestWorkspace ws = testing::MakeTestWorkspace(dir, 6, 1);
  for (const CalibratedFrame& frame : ws.cameras.frames) {
    const Intrinsics& k = ws.cameras.undistorted_view;
    WriteImage((fs::path(dir) / frame.image_8bit).string(), Image::FromMat(cv::Mat(k.height, k.width, CV_32FC3,
                                                                                   cv::Scalar(0, 0, 0))),
               PixelStorage::kUint8);
  }
  ReconstructOptions options;
  options.workspace = dir;
  try {
    RunReconstructImpl(options);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string message = e.what();
    std::cout << message << "\n";
    EXPECT_NE(message.find("too few points"), std::string::npos) << message;
    EXPECT_NE(message.find(ws.cameras.frames[0].name), std::string::npos) << message;
  }
  EXPECT_FALSE(fs::exists(fs::path(dir) / "reconstruct"));  // nothing half-written
  options.proxy.sparse_fallback = false;
  EXPECT_THROW(RunReconstructImpl(options), Error);
  std::error_code ignored;
  fs::remove_all(dir, ignored);
}

}  // namespace
}  // namespace relit::reconstruct
