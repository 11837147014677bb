// Silhouette refinement on a scene with a closed-form answer: a plain white
// sphere (no texture: the photometric search has nothing to match on it)
// above the ChArUco board, seen by two rings of cameras whose images are
// ray-traced analytically, anti-aliased, under a flash that moves from frame
// to frame and casts the sphere's shadow on the board.
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/aruco/charuco.hpp>

#include "core/board.h"
#include "core/error.h"
#include "core/render/mesh.h"
#include "reconstruct/silhouette_refine.h"
#include "reconstruct/test_workspace.h"

namespace relit::reconstruct {
namespace {

const Eigen::Vector3d kCentre(0.01, -0.02, 0.05);
constexpr double kRadius = 0.03;
constexpr double kInk = 0.03, kPaper = 0.8, kSphereAlbedo = 0.7;

const BoardSpec& Board() {
  static const BoardSpec spec = [] {
    BoardSpec s;
    s.dictionary = "DICT_4X4_50";
    return s;
  }();
  return spec;
}

// Linear radiance seen along `ray` from `eye`: the sphere (Lambert) or the
// board's print under the flash at `flash`, the sphere's shadow included.
double Radiance(const Eigen::Vector3d& eye, const Eigen::Vector3d& ray, const Eigen::Vector3d& flash,
                const BoardPrint& print) {
  constexpr double kPower = 0.1, kAmbient = 0.02;
  const double t = testing::RaySphere(eye, ray, kCentre, kRadius);
  Eigen::Vector3d hit, normal;
  double albedo;
  if (t > 0) {
    hit = eye + t * ray;
    normal = (hit - kCentre) / kRadius;
    albedo = kSphereAlbedo;
  } else if (ray.z() < 0) {
    hit = eye + (-eye.z() / ray.z()) * ray;
    normal = Eigen::Vector3d::UnitZ();
    albedo = kInk + (kPaper - kInk) * print.Albedo(hit);
  } else {
    return 0;
  }
  const Eigen::Vector3d to_light = flash - hit;
  const Eigen::Vector3d direction = to_light.normalized();
  const bool shadowed = t <= 0 && testing::RaySphere(hit, direction, kCentre, kRadius) > 0;
  const double direct = shadowed ? 0.0 : std::max(0.0, normal.dot(direction)) * kPower / to_light.squaredNorm();
  return albedo * (direct + kAmbient);
}

// 4 x 4 samples per pixel (a box filter, as a camera's pixel integrates).
Image RenderFrame(const Camera& camera, const Eigen::Vector3d& flash, const BoardPrint& print) {
  const Intrinsics& k = camera.intrinsics();
  Image image(k.width, k.height, 3);
  const Eigen::Vector3d eye = camera.Center();
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      double sum = 0;
      for (int j = 0; j < 4; ++j) {
        for (int i = 0; i < 4; ++i) {
          const Eigen::Vector2d pixel(u - 0.375 + 0.25 * i, v - 0.375 + 0.25 * j);
          sum += Radiance(eye, camera.PixelToWorldRay(pixel), flash, print);
        }
      }
      for (int c = 0; c < 3; ++c) image.at(u, v, c) = static_cast<float>(sum / 16);
    }
  }
  return image;
}

// Two rings of cameras; each frame's flash is held a quarter turn to one
// side of its camera or the other (phone L walks apart from phone V), so
// that the rims facing it are lit and the others in shadow.
std::vector<SilhouetteView> RenderViews() {
  static const std::vector<SilhouetteView> views = [] {
    const BoardPrint print(Board());
    std::vector<SilhouetteView> result;
    const std::vector<Camera> cameras = testing::TwoRingsOfCameras(kCentre, 20.0, 50.0);
    for (size_t i = 0; i < cameras.size(); ++i) {
      const Camera& camera = cameras[i];
      const Eigen::Vector3d from_centre = camera.Center() - kCentre;
      const double azimuth = std::atan2(from_centre.y(), from_centre.x()) + (i % 2 == 0 ? 1.0 : -1.0) * 1.4;
      const double elevation = 0.5 + 0.1 * static_cast<double>(i % 3);
      const Eigen::Vector3d flash =
          kCentre + 0.35 * Eigen::Vector3d(std::cos(azimuth) * std::cos(elevation),
                                           std::sin(azimuth) * std::cos(elevation), std::sin(elevation));
      const Image image = RenderFrame(camera, flash, print);
      result.push_back({camera, flash, [image] { return image; }});
    }
    return result;
  }();
  return views;
}

// Mean distance (or signed offset, + outside) from the true sphere of the
// vertices in the band the rings' outlines sweep (within half a radius of
// the equator's height).
double BandError(const render::TriangleMesh& mesh, bool signed_offset = false) {
  double sum = 0;
  int count = 0;
  for (const Eigen::Vector3f& p : mesh.positions) {
    if (std::abs(p.z() - kCentre.z()) > 0.5 * kRadius) continue;
    const double offset = (p.cast<double>() - kCentre).norm() - kRadius;
    sum += signed_offset ? offset : std::abs(offset);
    ++count;
  }
  return sum / count;
}

render::TriangleMesh Sphere(double radius) { return render::MakeSphere(kCentre.cast<float>(), radius, 48, 24); }

TEST(BoardPrintTest, PutsTheCornersWhereTheBoardsDetectorFindsThem) {
  const BoardPrint print(Board());
  const Camera camera = testing::CameraLookingAt(Eigen::Vector3d(0.02, -0.05, 0.5), Eigen::Vector3d::Zero(), 640,
                                                 480, 900);
  cv::Mat gray(480, 640, CV_8U);
  for (int v = 0; v < gray.rows; ++v) {
    for (int u = 0; u < gray.cols; ++u) {
      const Eigen::Vector3d ray = camera.PixelToWorldRay(Eigen::Vector2d(u, v));
      const Eigen::Vector3d hit = camera.Center() + (-camera.Center().z() / ray.z()) * ray;
      const bool on_print = std::abs(hit.x()) < 0.5 * Board().width_m() && std::abs(hit.y()) < 0.5 * Board().height_m();
      gray.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(on_print ? 20 + 215 * print.Albedo(hit) : 235);
    }
  }
  const auto board = MakeCharucoBoard(Board());
  std::vector<int> marker_ids;
  std::vector<std::vector<cv::Point2f>> markers;
  cv::aruco::detectMarkers(gray, board->dictionary, markers, marker_ids);
  std::vector<cv::Point2f> corners;
  std::vector<int> corner_ids;
  cv::aruco::interpolateCornersCharuco(markers, marker_ids, gray, board, corners, corner_ids);
  ASSERT_GE(corner_ids.size(), 20u);
  const std::vector<Eigen::Vector3d> world = CharucoCornersWorld(Board());
  for (size_t i = 0; i < corner_ids.size(); ++i) {
    Eigen::Vector2d expected;
    ASSERT_TRUE(camera.Project(world[static_cast<size_t>(corner_ids[i])], &expected));
    EXPECT_NEAR(corners[i].x, expected.x(), 0.5) << "corner " << corner_ids[i];
    EXPECT_NEAR(corners[i].y, expected.y(), 0.5) << "corner " << corner_ids[i];
  }
}

TEST(FitOutlineTest, FindsASubPixelStepAgainstThePrint) {
  // 21 samples half a pixel apart; the print alternates ink and paper.
  std::vector<float> albedo(21);
  for (size_t i = 0; i < albedo.size(); ++i) albedo[i] = (i / 3) % 2 == 0 ? 1.0f : 0.0f;
  for (double step : {-1.3, 0.0, 0.6}) {
    for (bool bright : {true, false}) {
      std::vector<Eigen::Vector3f> colours(21);
      for (size_t i = 0; i < colours.size(); ++i) {
        const double t = (static_cast<double>(i) - 10) * 0.5;
        const double a = std::clamp(0.5 + step - t, 0.0, 1.0);
        const Eigen::Vector3d object = bright ? Eigen::Vector3d(0.9, 0.8, 0.7) + 0.01 * t * Eigen::Vector3d::Ones()
                                              : Eigen::Vector3d(0.01, 0.02, 0.01);
        const Eigen::Vector3d board = Eigen::Vector3d(0.3, 0.3, 0.25) * (0.3 + 0.7 * albedo[i]) +
                                      Eigen::Vector3d::Constant(0.01);
        colours[i] = (a * object + (1 - a) * board).cast<float>();
      }
      const OutlineFit fit = FitOutline(colours, albedo, 0.5, 2.0);
      ASSERT_TRUE(fit.found);
      EXPECT_NEAR(fit.offset_px, step, 0.13) << "bright " << bright;
      EXPECT_EQ(fit.polarity > 0, bright);
      EXPECT_GT(fit.contrast, 10.0) << "step " << step << " bright " << bright;
    }
  }
}

TEST(SilhouetteRefineTest, AnOffsetPlainSphereMovesOntoItsOutline) {
  const std::vector<SilhouetteView> views = RenderViews();
  for (double offset_m : {0.0015, -0.0015}) {
    const render::TriangleMesh proxy = Sphere(kRadius + offset_m);
    ASSERT_NEAR(BandError(proxy), std::abs(offset_m), 1e-4);
    SilhouetteReport report;
    const render::TriangleMesh refined =
        RefineSilhouettes(proxy, views, BoardPrint(Board()), SilhouetteOptions{}, 0.0, &report);
    EXPECT_GT(report.voting_vertices_first, 200);
    EXPECT_LT(BandError(refined), 0.2e-3) << "offset " << offset_m;  // from 1.5 mm (1.5 px); 0.09 measured
  }
}

TEST(SilhouetteRefineTest, TheTrueSurfaceStaysPut) {
  const std::vector<SilhouetteView> views = RenderViews();
  SilhouetteReport report;
  const render::TriangleMesh refined =
      RefineSilhouettes(Sphere(kRadius), views, BoardPrint(Board()), SilhouetteOptions{}, 0.0, &report);
  EXPECT_LT(BandError(refined), 0.15e-3);
  EXPECT_LT(std::abs(BandError(refined, true)), 0.1e-3);
}

TEST(SilhouetteRefineTest, RefusesAFrameThatDoesNotMatchItsCamera) {
  std::vector<SilhouetteView> views = RenderViews();
  views[3].load_image = [] { return Image(10, 10, 3); };
  SilhouetteReport report;
  EXPECT_THROW(RefineSilhouettes(Sphere(kRadius), views, BoardPrint(Board()), SilhouetteOptions{}, 0.0, &report),
               Error);
}

}  // namespace
}  // namespace relit::reconstruct
