// Unit tests of the calib stage's parts on small synthetic inputs: options,
// board detection (OpenCV and libapriltag) on a warped board image, the
// marker ratio check, the robust similarity, light interpolation, the
// bundle adjustment, the COLMAP text model reader and the pinhole choice.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <iostream>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "calib/align.h"
#include "calib/board_detect.h"
#include "calib/board_pose.h"
#include "calib/board_test_util.h"
#include "calib/bundle.h"
#include "calib/bundle_test_util.h"
#include "calib/calib_options.h"
#include "calib/calib_steps.h"
#include "calib/colmap_sfm.h"
#include "calib/lights.h"
#include "calib/truth_accuracy.h"
#include "calib/undistort.h"
#include "core/error.h"

namespace relit::calib {
namespace {

namespace fs = std::filesystem;

// A synthetic truth is for the stored pixels; capture turns frames by their
// display rotation. The turned lens and pose must put every world point
// where the turned image shows it.
TEST(TruthDisplayTest, TurnedLensAndPoseProjectWhereTheTurnedImageShows) {
  Intrinsics stored = Intrinsics::FromFov(384, 216, 70 * M_PI / 180);
  stored.cx += 3.5;
  stored.cy -= 2.0;
  stored.fy = stored.fx * 1.01;
  stored.distortion = {0.06, 0.01, -0.0002, 0.0005, 0.001};
  const Rigid3 pose = LookAt({0.3, -0.2, 0.25}, {0.01, 0.02, 0.05}, Eigen::Vector3d::UnitZ());
  const Camera camera(stored, pose);
  const int w = stored.width, h = stored.height;
  for (int rotation : {0, 90, 180, 270}) {
    const Camera turned(DisplayedIntrinsics(stored, rotation), DisplayedCamFromWorld(pose, rotation));
    for (const Eigen::Vector3d& point : {Eigen::Vector3d(0, 0, 0.05), Eigen::Vector3d(0.08, -0.05, 0.0),
                                        Eigen::Vector3d(-0.1, 0.07, 0.02)}) {
      Eigen::Vector2d p, q;
      ASSERT_TRUE(camera.Project(point, &p));
      ASSERT_TRUE(turned.Project(point, &q));
      Eigen::Vector2d expected = p;  // where the clockwise turn moves stored pixel p
      if (rotation == 90) expected = {h - 1 - p.y(), p.x()};
      if (rotation == 180) expected = {w - 1 - p.x(), h - 1 - p.y()};
      if (rotation == 270) expected = {p.y(), w - 1 - p.x()};
      EXPECT_NEAR((q - expected).norm(), 0.0, 1e-9) << "rotation " << rotation;
    }
    const Eigen::Vector3d flash = DisplayedCameraPoint({0.01, 0.002, 0}, rotation);
    EXPECT_NEAR((turned.world_from_cam() * flash - camera.world_from_cam() * Eigen::Vector3d(0.01, 0.002, 0)).norm(),
                0.0, 1e-12);
  }
  EXPECT_THROW(DisplayedIntrinsics(stored, 45), std::runtime_error);
}

TEST(CalibOptionsTest, UnknownKeysAndBadBoardsAreErrors) {
  CalibOptions o;
  OptionsReader typo = OptionsReader::FromString("sfm: {enabeld: false}\n", "calib.yaml");
  EXPECT_THROW(ReadOptions(typo, &o), Error);
  CalibOptions even;
  OptionsReader rows = OptionsReader::FromString("workspace: w\nboard: {squares_y: 6}\n", "calib.yaml");
  ReadOptions(rows, &even);
  EXPECT_THROW(CheckOptions(even), Error);
  CalibOptions ok;
  OptionsReader good = OptionsReader::FromString(
      "workspace: w\nboard: {squares_x: 9, squares_y: 7, dictionary: DICT_4X4_50}\nlight: {flash_offset_m: [0.01, 0, 0]}\n",
      "calib.yaml");
  ReadOptions(good, &ok);
  CheckOptions(ok);
  EXPECT_EQ(ok.board.squares_x, 9);
  EXPECT_EQ(OptionsToJson(ok)["board"]["dictionary"], "DICT_4X4_50");
  ok.light.flash_offset_m = {0.0, 1.0};
  EXPECT_THROW(CheckOptions(ok), Error);
  CalibOptions modes;
  OptionsReader mode = OptionsReader::FromString("workspace: w\nsfm: {mode: hierarchical}\n", "calib.yaml");
  EXPECT_THROW(ReadOptions(mode, &modes), Error);
  modes.sfm.mode = "hierarchical";
  EXPECT_THROW(CheckOptions(modes), Error);
  CalibOptions solver;
  OptionsReader cg = OptionsReader::FromString("workspace: w\nrefine: {linear_solver: cholesky}\n", "calib.yaml");
  EXPECT_THROW(ReadOptions(cg, &solver), Error);
}

// sfm.mode auto: the seeded path only at capture scale and only when the
// board can seed it; explicit modes are taken as they are.
TEST(CalibOptionsTest, AutoSfmModeFollowsImagesAndSeeds) {
  SfmOptions so;
  EXPECT_EQ(so.mode, "auto");
  std::string why;
  EXPECT_EQ(ResolveSfmMode(so, 220, 200, &why), "incremental");
  EXPECT_NE(why.find("fewer than sfm.auto_seeded_min_images"), std::string::npos) << why;
  EXPECT_EQ(ResolveSfmMode(so, 500, 480, &why), "board_seeded");
  EXPECT_EQ(ResolveSfmMode(so, 3000, 1, &why), "incremental");
  EXPECT_NE(why.find("1 frames"), std::string::npos) << why;
  so.auto_seeded_min_images = 100;
  EXPECT_EQ(ResolveSfmMode(so, 220, 200, &why), "board_seeded");
  so.mode = "incremental";
  EXPECT_EQ(ResolveSfmMode(so, 3000, 2900, &why), "incremental");
  so.mode = "board_seeded";
  EXPECT_EQ(ResolveSfmMode(so, 10, 0, &why), "board_seeded");  // its own check names the missing seeds
}

// A board image warped by a known homography; `truth` receives the board
// corners' pixel positions.
cv::Mat WarpedBoard(const BoardSpec& spec, std::vector<Eigen::Vector2d>* truth) {
  const double ppm = 4000;  // pixels per metre of the drawn board
  const int margin = 40;
  const cv::Mat board = DrawBoardImage(spec, ppm, margin);
  const cv::Point2f src[4] = {{0, 0}, {float(board.cols), 0}, {float(board.cols), float(board.rows)}, {0, float(board.rows)}};
  const cv::Point2f dst[4] = {{60, 50}, {1000, 90}, {1060, 700}, {30, 740}};
  const cv::Mat h = cv::getPerspectiveTransform(src, dst);
  cv::Mat warped;
  // Area-averaged warp: supersample 4x, then reduce.
  cv::Mat big_h = (cv::Mat_<double>(3, 3) << 4, 0, 1.5, 0, 4, 1.5, 0, 0, 1) * h;
  cv::warpPerspective(board, warped, big_h, cv::Size(4 * 1100, 4 * 800), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 255);
  cv::resize(warped, warped, cv::Size(1100, 800), 0, 0, cv::INTER_AREA);
  *truth = WarpedCornersPx(spec, ppm, margin, h);
  return warped;
}

TEST(BoardDetectTest, OpenCvAndAprilTagAgreeAndCornersAreAccurate) {
  BoardSpec spec;  // 7x5, 40 mm squares, 30 mm AprilTag 36h11 markers
  std::vector<Eigen::Vector2d> truth;
  const cv::Mat image = WarpedBoard(spec, &truth);
  DetectOptions options;
  options.apriltag = "always";
  const BoardDetector detector(spec, options);
  ASSERT_TRUE(detector.apriltag_available());
  const auto opencv = detector.DetectOpenCv(image);
  const auto apriltag = detector.DetectAprilTag(image);
  EXPECT_EQ(static_cast<int>(opencv.size()), detector.marker_count());
  EXPECT_EQ(static_cast<int>(apriltag.size()), detector.marker_count());
  int compared = 0;
  for (const MarkerCorners& a : apriltag) {
    for (const MarkerCorners& o : opencv) {
      if (a.id != o.id) continue;
      for (int k = 0; k < 4; ++k) EXPECT_LT((a.corners_px[k] - o.corners_px[k]).norm(), 3.0) << a.id << " " << k;
      ++compared;
    }
  }
  EXPECT_EQ(compared, detector.marker_count());
  const BoardObservation obs = detector.Detect(image);
  ASSERT_EQ(static_cast<int>(obs.corner_ids.size()), spec.corner_count());
  double worst = 0;
  for (size_t i = 0; i < obs.corner_ids.size(); ++i) {
    worst = std::max(worst, (obs.corners_px[i] - truth[obs.corner_ids[i]]).norm());
  }
  EXPECT_LT(worst, 0.3);
  // Marker-to-square ratio from the image against the configured one.
  Intrinsics pinhole = Intrinsics::FromFov(1100, 800, 1.0);
  const double ratio = MeasureMarkerRatio(obs, pinhole, spec);
  EXPECT_NEAR(ratio, spec.marker_length_m / spec.square_length_m, 0.02);
  // A board configured with the wrong square size measures differently.
  BoardSpec wrong = spec;
  wrong.square_length_m = 0.045;
  EXPECT_NEAR(MeasureMarkerRatio(obs, pinhole, wrong), 0.75, 0.02);
}

// Half the board in deep shadow (a flash shadow): the corners next to a
// single found marker are added where the image shows a chessboard corner,
// accurately, and none where it shows nothing.
TEST(BoardDetectTest, CornersNextToOneMarkerUnderAShadow) {
  BoardSpec spec;
  spec.dictionary = "DICT_4X4_50";
  std::vector<Eigen::Vector2d> truth;
  cv::Mat image = WarpedBoard(spec, &truth);
  const int shadow_x = 560;
  image(cv::Rect(shadow_x, 0, image.cols - shadow_x, image.rows)).setTo(6);
  DetectOptions pairs;
  pairs.min_adjacent_markers = 2;
  const BoardObservation strict = BoardDetector(spec, pairs).Detect(image);
  DetectOptions rescue;  // single-marker corners only rescue frames with too few pair corners
  rescue.min_corners = 10;
  const BoardObservation obs = BoardDetector(spec, rescue).Detect(image);
  EXPECT_EQ(BoardDetector(spec, DetectOptions()).Detect(image).corners_single_marker, 0);  // 8 >= 6
  std::cout << "shadowed board: " << obs.markers.size() << " markers, corners " << strict.corner_ids.size()
            << " (two markers) -> " << obs.corner_ids.size() << " (" << obs.corners_single_marker
            << " next to one marker)\n";
  EXPECT_LT(obs.markers.size(), 12u);
  EXPECT_GT(obs.corners_single_marker, 2);
  EXPECT_EQ(obs.corner_ids.size(), strict.corner_ids.size() + obs.corners_single_marker);
  for (size_t i = 0; i < obs.corner_ids.size(); ++i) {
    EXPECT_LT((obs.corners_px[i] - truth[obs.corner_ids[i]]).norm(), 0.5) << "corner " << obs.corner_ids[i];
    EXPECT_LT(obs.corners_px[i].x(), shadow_x - 2) << "corner " << obs.corner_ids[i] << " in the shadow";
  }
  // The corner test itself: a corner, an edge, a flat patch.
  const cv::Point2f corner(truth[0].x(), truth[0].y());
  EXPECT_GT(XCornerContrast(image, corner, 3.0), 100);
  EXPECT_EQ(XCornerContrast(image, cv::Point2f(shadow_x + 40, 300), 3.0), 0.0);
  EXPECT_EQ(XCornerContrast(image, cv::Point2f(shadow_x, 300), 3.0), 0.0);  // the shadow's edge
}

TEST(AlignTest, RobustSimilarityIgnoresOutliers) {
  Similarity3 truth;
  truth.scale = 0.37;
  truth.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  truth.translation = Eigen::Vector3d(0.1, -0.2, 0.3);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 1);
  std::vector<Eigen::Vector3d> src, dst;
  for (int i = 0; i < 40; ++i) {
    const Eigen::Vector3d p(noise(rng), noise(rng), noise(rng));
    src.push_back(p);
    Eigen::Vector3d q = truth * p;
    if (i % 5 == 0) q += Eigen::Vector3d(0.3, 0, 0);  // outliers
    dst.push_back(q);
  }
  RobustFit fit;
  ASSERT_TRUE(FitSimilarityRobust(src, dst, 0.01, 300, &fit));
  EXPECT_EQ(fit.inlier_count, 32);
  EXPECT_NEAR(fit.transform.scale, truth.scale, 1e-9);
  EXPECT_LT((fit.transform.rotation - truth.rotation).norm(), 1e-9);
  // Camera poses follow the points.
  const Rigid3 cam_from_model(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY())), Eigen::Vector3d(0.2, 0.1, 2));
  const Rigid3 cam_from_world = fit.transform.CamFromWorld(cam_from_model);
  const Eigen::Vector3d x_model(0.3, -0.4, 0.5);
  EXPECT_LT((cam_from_world * (truth * x_model) - truth.scale * (cam_from_model * x_model)).norm(), 1e-9);
}

TEST(LightsTest, CubicInterpolationOfACircularPath) {
  const double radius = 0.35, omega = 9.4;  // rad/s, as phone L of the tiny preset
  auto pose_at = [&](double t) {
    const Eigen::Vector3d eye(radius * std::cos(omega * t), radius * std::sin(omega * t), 0.2);
    return LookAt(eye, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
  };
  const Eigen::Vector3d offset(0.01, 0, 0);
  std::vector<TimedPose> poses;
  for (int i = 0; i < 30; ++i) poses.push_back({i / 30.0, pose_at(i / 30.0)});
  std::vector<TimedName> views;
  for (int i = 0; i < 10; ++i) views.push_back({"view/" + std::to_string(i), 0.1 + i * 0.0787});
  views.push_back({"view/late", 1.5});
  const LightsFile lights = InterpolateLights(views, poses, offset, 0.05);
  ASSERT_EQ(lights.frames.size(), views.size());
  for (size_t i = 0; i + 1 < views.size(); ++i) {
    const Eigen::Vector3d truth = FlashPosition(pose_at(views[i].time_s), offset);
    EXPECT_LT((lights.frames[i].position_m - truth).norm(), 2e-4) << views[i].time_s;
    EXPECT_TRUE(lights.frames[i].reliable);
    EXPECT_LE(lights.frames[i].nearest_light_gap_s, 1 / 60.0 + 1e-9);
  }
  EXPECT_FALSE(lights.frames.back().reliable);
  EXPECT_NEAR(lights.frames.back().nearest_light_gap_s, 1.5 - 29 / 30.0, 1e-9);
  const nlohmann::json coverage = CoverageSummary({Eigen::Vector3d(1, 0, 1)}, {Eigen::Vector3d(0, 1, 0.1)},
                                                  Eigen::Vector3d::Zero());
  EXPECT_EQ(coverage["view_histogram"][1][0], 1);   // 45 deg elevation, azimuth 0
  EXPECT_EQ(coverage["light_histogram"][0][2], 1);  // low, azimuth 90 deg
}

TEST(BundleTest, RecoversLensAndPosesFromBoardCorners) {
  BoardSpec spec;
  Intrinsics truth = Intrinsics::FromFov(640, 480, 1.1);
  truth.cx += 5;
  truth.distortion = {0.08, -0.03, 0.0004, -0.0003, 0};
  BundleProblem problem;
  problem.square_pixels = true;
  problem.refine_tangential = false;
  truth.distortion.p1 = truth.distortion.p2 = 0;
  problem.corners_world = CharucoCornersWorld(spec);
  problem.devices["view"] = truth;
  problem.devices["view"].fx *= 1.03;
  problem.devices["view"].fy = problem.devices["view"].fx;
  problem.devices["view"].distortion = {};
  std::vector<Rigid3> poses;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 0.02);
  for (int i = 0; i < 12; ++i) {
    const double a = i * 0.5;
    const Eigen::Vector3d eye(0.35 * std::cos(a), 0.35 * std::sin(a), 0.08 + 0.04 * i);
    poses.push_back(LookAt(eye, Eigen::Vector3d(0.01 * std::sin(3 * a), 0, 0), Eigen::Vector3d::UnitZ()));
    BundleFrame f;
    f.device = "view";
    f.posed = true;
    const Camera camera(truth, poses.back());
    for (size_t c = 0; c < problem.corners_world.size(); ++c) {
      Eigen::Vector2d px;
      if (!camera.Project(problem.corners_world[c], &px)) continue;
      f.corner_ids.push_back(static_cast<int>(c));
      f.corners_px.push_back(px + Eigen::Vector2d(noise(rng), noise(rng)));
    }
    f.cam_from_world = Rigid3(poses.back().rotation * Eigen::Quaterniond(Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitX())),
                              poses.back().translation + Eigen::Vector3d(0.01, -0.01, 0.02));
    problem.frames.push_back(f);
  }
  problem.frames[3].corners_px[2] += Eigen::Vector2d(30, 0);  // an outlier
  const BundleStats stats = RefineBundle(&problem, BundleOptions{});
  std::cout << "iters " << stats.iterations << " cost " << stats.initial_cost << " -> " << stats.final_cost << " rms " << stats.corner_rms_px << " obs " << stats.corner_observations << "\n";
  EXPECT_EQ(stats.corner_outliers, 1);
  EXPECT_LT(stats.corner_rms_px, 0.03);
  EXPECT_NEAR(problem.devices["view"].fx / truth.fx, 1.0, 2e-3);
  EXPECT_NEAR(problem.devices["view"].distortion.k1, truth.distortion.k1, 0.01);
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_LT((problem.frames[i].cam_from_world.Inverse().translation - poses[i].Inverse().translation).norm(), 1e-3);
  }
}

// Board corners plus SfM points: the three linear solvers (points eliminated
// first for the sparse and iterative ones) reach the same poses and lens.
TEST(BundleTest, LinearSolversAgreeWithPoints) {
  std::vector<Rigid3> poses;
  const BundleProblem base = BoardAndPoints(0.1, &poses);
  std::map<std::string, BundleProblem> solved;
  for (const std::string solver : {"dense_schur", "sparse_schur", "iterative_schur"}) {
    BundleProblem p = base;
    BundleOptions o;
    o.linear_solver = solver;
    o.function_tolerance = 1e-10;  // the optimum, not the stop criterion (iterative_schur stops early at 1e-6)
    const BundleStats stats = RefineBundle(&p, o);
    EXPECT_EQ(stats.linear_solver, solver == "dense_schur" ? "DENSE_SCHUR"
                                   : solver == "sparse_schur" ? "SPARSE_SCHUR" : "ITERATIVE_SCHUR");
    EXPECT_GT(stats.point_observations, 400) << solver;
    EXPECT_LT(stats.corner_rms_px, 0.2) << solver;
    for (int i = 0; i < 16; ++i) {
      // 0.1 px noise on 16 frames: ~1-2 mm; the solvers' agreement is checked below.
      EXPECT_LT((p.frames[i].cam_from_world.Inverse().translation - poses[i].Inverse().translation).norm(), 3e-3)
          << solver << " frame " << i;
    }
    solved[solver] = p;
  }
  for (const std::string solver : {"sparse_schur", "iterative_schur"}) {
    EXPECT_NEAR(solved[solver].devices["view"].fx, solved["dense_schur"].devices["view"].fx, 0.05) << solver;
    for (int i = 0; i < 16; ++i) {
      EXPECT_LT((solved[solver].frames[i].cam_from_world.translation -
                 solved["dense_schur"].frames[i].cam_from_world.translation).norm(), 1e-4) << solver;  // 0.1 mm
    }
  }
}

// auto: sparse Schur on board corners alone (the reduced system is block
// diagonal apart from the lens rows; 990 frames: 0.6 s against dense 37.6 s),
// dense Schur with SfM points up to dense_schur_max_frames, iterative beyond.
TEST(BundleTest, AutoSolverFollowsPointsAndFrames) {
  std::vector<Rigid3> poses;
  const BundleProblem base = BoardAndPoints(0.1, &poses);
  BundleOptions o;  // auto
  BundleProblem with_points = base;
  EXPECT_EQ(RefineBundle(&with_points, o).linear_solver, "DENSE_SCHUR");
  BundleProblem corners_only = base;
  corners_only.points.clear();
  EXPECT_EQ(RefineBundle(&corners_only, o).linear_solver, "SPARSE_SCHUR");
  // iterative_schur serves the joint solve only: on board corners alone
  // conjugate gradients took 88 iterations where sparse Schur takes 12 (990 frames).
  BundleOptions iterative;
  iterative.linear_solver = "iterative_schur";
  BundleProblem corners_iterative = corners_only;
  EXPECT_EQ(RefineBundle(&corners_iterative, iterative).linear_solver, "SPARSE_SCHUR");
  BundleProblem many_frames = base;
  o.dense_schur_max_frames = 10;  // the problem has 16
  EXPECT_EQ(RefineBundle(&many_frames, o).linear_solver, "ITERATIVE_SCHUR");
  BundleProblem many_frames_corners = base;
  many_frames_corners.points.clear();
  EXPECT_EQ(RefineBundle(&many_frames_corners, o).linear_solver, "SPARSE_SCHUR");
  o.linear_solver = "dense_schur";  // the choice before: dense on board corners alone too
  corners_only = base;
  corners_only.points.clear();
  EXPECT_EQ(RefineBundle(&corners_only, o).linear_solver, "DENSE_SCHUR");
}

// Dense Schur's Cholesky from Ceres' Eigen or from LAPACK (OpenBLAS when
// installed, auto's choice then): the same solution.
TEST(BundleTest, DenseLibrariesAgree) {
  std::vector<Rigid3> poses;
  const BundleProblem base = BoardAndPoints(0.1, &poses);
  BundleProblem eigen = base, lapack = base;
  BundleOptions o;
  o.linear_solver = "dense_schur";
  o.function_tolerance = 1e-10;
  o.dense_library = "eigen";
  EXPECT_EQ(RefineBundle(&eigen, o).dense_library, "EIGEN");
  o.dense_library = "lapack";
  EXPECT_EQ(RefineBundle(&lapack, o).dense_library, "LAPACK");
  EXPECT_NEAR(lapack.devices["view"].fx, eigen.devices["view"].fx, 1e-6);
  for (int i = 0; i < 16; ++i) {
    EXPECT_LT((lapack.frames[i].cam_from_world.translation - eigen.frames[i].cam_from_world.translation).norm(),
              1e-8);
  }
}

// refine.first_max_iterations caps the first solve (the one before the
// outliers are dropped) and leaves the second to its own criterion.
TEST(BundleTest, FirstSolveIterationCap) {
  std::vector<Rigid3> poses;
  const BundleProblem base = BoardAndPoints(0.3, &poses);
  BundleOptions o;
  o.first_function_tolerance = 1e-12;  // never met: the first solve runs to its cap
  BundleProblem uncapped = base;
  const BundleStats all = RefineBundle(&uncapped, o);
  EXPECT_GT(all.iterations - all.final_iterations, 3);
  o.first_max_iterations = 2;
  BundleProblem capped = base;
  const BundleStats two = RefineBundle(&capped, o);
  EXPECT_LE(two.iterations - two.final_iterations, 3);  // Ceres counts iteration 0 too
  EXPECT_LT(two.final_iterations, o.max_iterations);
  for (int i = 0; i < 16; ++i) {
    EXPECT_LT((capped.frames[i].cam_from_world.Inverse().translation - poses[i].Inverse().translation).norm(), 8e-3)
        << "frame " << i;
  }
}

// The second solve at final_huber_px = outlier_px (every inlier in Huber's
// quadratic part) after a loose first solve: the same poses and lens as
// Huber 1 px to the end, within the noise.
TEST(BundleTest, QuadraticSecondSolveAgreesWithHuber) {
  std::vector<Rigid3> poses;
  const BundleProblem base = BoardAndPoints(0.3, &poses);
  std::map<double, BundleProblem> solved;
  for (const double final_huber_px : {0.0, 3.0}) {
    BundleProblem p = base;
    BundleOptions o;
    o.function_tolerance = 1e-10;
    o.final_huber_px = final_huber_px;
    if (final_huber_px > 0) o.first_function_tolerance = 1e-3;
    const BundleStats stats = RefineBundle(&p, o);
    EXPECT_GT(stats.final_iterations, 0);
    EXPECT_LT(stats.final_iterations, o.max_iterations) << "final_huber_px " << final_huber_px;
    for (int i = 0; i < 16; ++i) {
      EXPECT_LT((p.frames[i].cam_from_world.Inverse().translation - poses[i].Inverse().translation).norm(), 8e-3)
          << "final_huber_px " << final_huber_px << " frame " << i;
    }
    solved[final_huber_px] = p;
  }
  EXPECT_NEAR(solved[3.0].devices["view"].fx, solved[0.0].devices["view"].fx, 2.0);
  for (int i = 0; i < 16; ++i) {
    EXPECT_LT((solved[3.0].frames[i].cam_from_world.Inverse().translation -
               solved[0.0].frames[i].cam_from_world.Inverse().translation).norm(), 1e-3) << "frame " << i;
  }
}

// A board clip as relit-synth films one (tilted 5-40 degrees, filling the
// frame) with 6 corners misplaced by 5 px, as interpolateCornersCharuco does
// under strong perspective: the lens fit drops exactly those and recovers
// the lens; a plain least-squares fit would be pulled off by them.
TEST(BoardLensTest, MisplacedCornersAreDroppedAndTheLensRecovered) {
  BoardSpec spec;
  Intrinsics truth = Intrinsics::FromFov(320, 240, 67.0 * M_PI / 180.0);
  truth.cx += 3.8;
  truth.cy -= 1.9;
  truth.distortion = {0.09, -0.03, 0, 0, 0};
  const std::vector<Eigen::Vector3d> corners_world = CharucoCornersWorld(spec);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0, 0.1);
  std::vector<BoardObservation> frames;
  for (int i = 0; i < 14; ++i) {
    const double tilt = (8 + 2.3 * i) * M_PI / 180.0, azimuth = 2.4 * i;
    const Eigen::Vector3d aim(0.03 * std::cos(5.0 * i), 0.02 * std::sin(3.0 * i), 0);
    const Eigen::Vector3d eye = aim + 0.22 * Eigen::Vector3d(std::sin(tilt) * std::cos(azimuth),
                                                             std::sin(tilt) * std::sin(azimuth), std::cos(tilt));
    const Camera camera(truth, LookAt(eye, aim, Eigen::Vector3d(-std::cos(azimuth + 0.3 * i), -std::sin(azimuth + 0.3 * i), 0)));
    BoardObservation o;
    for (size_t c = 0; c < corners_world.size(); ++c) {
      Eigen::Vector2d px;
      if (!camera.Project(corners_world[c], &px) || px.x() < 2 || px.y() < 2 || px.x() > 317 || px.y() > 237) continue;
      o.corner_ids.push_back(static_cast<int>(c));
      o.corners_px.push_back(px + Eigen::Vector2d(noise(rng), noise(rng)));
    }
    frames.push_back(o);
  }
  int misplaced = 0;
  for (int i : {1, 4, 6, 9, 11, 13}) {
    ASSERT_GT(frames[i].corners_px.size(), 8u);
    frames[i].corners_px[4] += Eigen::Vector2d(3.0, -4.0);
    ++misplaced;
  }
  std::vector<const BoardObservation*> observations;
  for (const BoardObservation& o : frames) observations.push_back(&o);
  const BoardCalibration c = CalibrateFromBoard(observations, spec, 320, 240, false, true, false, 6, 60, "view");
  std::cout << "f " << c.intrinsics.fx << " vs " << truth.fx << ", c " << c.intrinsics.cx << ", " << c.intrinsics.cy
            << " vs " << truth.cx << ", " << truth.cy << ", rms " << c.rms_px << ", rejected " << c.corners_rejected << "\n";
  EXPECT_EQ(c.corners_rejected, misplaced);
  int detected = 0;
  for (const BoardObservation& o : frames) detected += static_cast<int>(o.corner_ids.size());
  EXPECT_EQ(c.corners_used + c.corners_rejected, detected);
  EXPECT_LT(c.rms_px, 0.15);
  EXPECT_NEAR(c.intrinsics.fx / truth.fx, 1.0, 0.003);
  EXPECT_NEAR(c.intrinsics.cx, truth.cx, 0.5);
  EXPECT_NEAR(c.intrinsics.cy, truth.cy, 0.5);
  EXPECT_NEAR(c.intrinsics.distortion.k1, truth.distortion.k1, 0.02);
}

TEST(ColmapTest, TextModelRoundTripUsesPixelCentres) {
  const fs::path dir = fs::temp_directory_path() / ("relit_calib_model_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  {
    std::ofstream images(dir / "images.txt");
    images << "# comment\n1 1 0 0 0 0.1 0.2 0.3 1 view/000000.png\n10.5 20.5 7 3.5 4.5 -1\n"
              "2 1 0 0 0 0.2 0.2 0.3 1 light/000001.png\n30.5 40.5 7\n";
    std::ofstream points(dir / "points3D.txt");
    points << "# comment\n7 0.5 0.6 0.7 255 0 0 0.4 1 0 2 0\n";
  }
  const SfmModel model = ReadColmapTextModel(dir.string());
  ASSERT_EQ(model.cam_from_model.size(), 2u);
  EXPECT_NEAR(model.cam_from_model.at("light/000001.png").translation.x(), 0.2, 1e-12);
  ASSERT_EQ(model.tracks.size(), 1u);
  ASSERT_EQ(model.tracks[0].size(), 2u);
  EXPECT_EQ(model.tracks[0][0].image, "view/000000.png");
  EXPECT_NEAR(model.tracks[0][0].pixel_px.x(), 10.0, 1e-12);
  EXPECT_NEAR(model.tracks[0][1].pixel_px.y(), 40.0, 1e-12);
  fs::remove_all(dir);
}

TEST(UndistortTest, PinholeWithAlphaZeroOnlySeesValidPixels) {
  Intrinsics lens = Intrinsics::FromFov(320, 240, 67.0 * M_PI / 180);
  lens.cx += 3;
  lens.distortion = {0.09, -0.03, 0.0004, -0.0003, 0};
  const Intrinsics pinhole = PinholeFor(lens, 0.0);
  cv::Mat map_x, map_y;
  UndistortionMaps(lens, pinhole, &map_x, &map_y);
  for (int y : {0, 119, 239}) {
    for (int x : {0, 160, 319}) {
      EXPECT_GE(map_x.at<float>(y, x), -0.5f);
      EXPECT_LE(map_x.at<float>(y, x), 319.5f);
      EXPECT_GE(map_y.at<float>(y, x), -0.5f);
      EXPECT_LE(map_y.at<float>(y, x), 239.5f);
    }
  }
  // Tight: somewhere along its border the pinhole image reaches a source border.
  double slack = 1e9;
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; x += (y == 0 || y == 239) ? 1 : 319) {
      const double mx = map_x.at<float>(y, x), my = map_y.at<float>(y, x);
      slack = std::min({slack, mx, 319 - mx, my, 239 - my});
      EXPECT_GE(std::min({mx, 319 - mx, my, 239 - my}), -0.01);
    }
  }
  EXPECT_LT(slack, 0.5);
  EXPECT_GT(PinholeFor(lens, 1.0).fx, 0.0);
}

// A fine pattern (period 4-5 px, below Nyquist) resampled into the pinhole
// camera keeps its contrast with the cubic kernel; bilinear averages it
// away by the fractional part of each source position.
TEST(UndistortTest, CubicKeepsFineDetailThatBilinearBlurs) {
  Intrinsics lens = Intrinsics::FromFov(320, 240, 67.0 * M_PI / 180);
  lens.distortion = {0.09, -0.06, 0, 0, 0};
  const Intrinsics pinhole = PinholeFor(lens, 0.0);
  const auto pattern = [](double x, double y) {
    return 0.5 + 0.4 * std::sin(2 * M_PI * x / 4.0) * std::sin(2 * M_PI * y / 5.0);
  };
  cv::Mat source(240, 320, CV_32F);
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) source.at<float>(y, x) = static_cast<float>(pattern(x, y));
  }
  cv::Mat map_x, map_y;
  UndistortionMaps(lens, pinhole, &map_x, &map_y);
  const auto rms_error = [&](const std::string& interpolation) {
    const cv::Mat out = FrameUndistorter(lens, pinhole, interpolation).Remap(source);
    double sum = 0;
    int n = 0;
    for (int y = 20; y < 220; ++y) {
      for (int x = 20; x < 300; ++x, ++n) {
        const double d = out.at<float>(y, x) - pattern(map_x.at<float>(y, x), map_y.at<float>(y, x));
        sum += d * d;
      }
    }
    return std::sqrt(sum / n);
  };
  const double linear = rms_error("linear"), cubic = rms_error("cubic"), lanczos = rms_error("lanczos4");
  EXPECT_GT(linear, 0.05);  // measured 0.062 of the amplitude 0.4; cubic 0.005, lanczos4 0.004
  EXPECT_LT(cubic, 0.5 * linear);
  EXPECT_LT(lanczos, 0.5 * linear);
  EXPECT_THROW(FrameUndistorter(lens, pinhole, "nearest"), Error);

  // An edge: the cubic kernel's overshoot never makes radiance negative.
  cv::Mat edge(240, 320, CV_32F, cv::Scalar(0));
  edge.colRange(160, 320).setTo(1);
  double lowest = 0;
  cv::minMaxLoc(FrameUndistorter(lens, pinhole, "cubic").Remap(edge), &lowest);
  EXPECT_GE(lowest, 0.0);
}

}  // namespace
}  // namespace relit::calib
