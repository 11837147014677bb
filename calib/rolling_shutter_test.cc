// The rolling-shutter model of the joint refinement (calib/rolling_shutter.h):
// which pixel was read when, frame motion from neighbours, and a bundle of
// board frames filmed by an orbiting rolling-shutter camera, whose lens
// comes out long unless the readout is modelled.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "calib/bundle.h"
#include "calib/rolling_shutter.h"
#include "core/board.h"

namespace relit::calib {
namespace {

// The readout runs along the stored rows, whatever the display rotation:
// a stored pixel and where the clockwise turn puts it are read at one time.
TEST(RollingShutterTest, ReadoutFollowsTheStoredRows) {
  const int w = 64, h = 48;
  for (const Eigen::Vector2d& stored : {Eigen::Vector2d(3, 0), Eigen::Vector2d(40, 47), Eigen::Vector2d(10, 20)}) {
    const double expected = (stored.y() + 0.5) / h - 0.5;
    EXPECT_DOUBLE_EQ(ReadoutFraction(stored, w, h, 0), expected);
    EXPECT_DOUBLE_EQ(ReadoutFraction({h - 1 - stored.y(), stored.x()}, h, w, 90), expected);
    EXPECT_DOUBLE_EQ(ReadoutFraction({w - 1 - stored.x(), h - 1 - stored.y()}, w, h, 180), expected);
    EXPECT_DOUBLE_EQ(ReadoutFraction({stored.y(), w - 1 - stored.x()}, h, w, 270), expected);
  }
  EXPECT_DOUBLE_EQ(ReadoutFraction({0, -0.5}, w, h, 0), -0.5);
  EXPECT_DOUBLE_EQ(ReadoutFraction({0, h - 0.5}, w, h, 0), 0.5);
}

// A camera circling the board at `rate_rad_s` while it moves in and out
// and up and down (the lens is observable from the changing distance),
// looking near the board's centre: phone L's wandering path.
Rigid3 Orbit(double t_s, double rate_rad_s) {
  const double a = rate_rad_s * t_s;
  const double r = 0.45 + 0.2 * std::sin(2.1 * t_s);
  const Eigen::Vector3d eye(r * std::cos(a), r * std::sin(a), 0.32 + 0.2 * std::sin(1.7 * t_s + 1));
  const Eigen::Vector3d target(0.02 * std::sin(2.9 * t_s), 0.02 * std::cos(2.3 * t_s), 0);
  return LookAt(eye, target, Eigen::Vector3d::UnitZ());
}

TEST(RollingShutterTest, MotionFromNeighboursOfTheSameVideo) {
  const double rate = 1.0, fps = 30;
  std::vector<TimedFrame> frames;
  for (int i = 0; i < 5; ++i) frames.push_back({"light", i / fps, true, Orbit(i / fps, rate)});
  frames.push_back({"light", 2.0, true, Orbit(2.0, rate)});  // 1.9 s after the others: no neighbour
  frames.push_back({"", 0.05, true, Orbit(0.05, rate)});      // a still photo
  frames.push_back({"view", 0.0, true, Orbit(0.0, rate)});    // alone in its video
  const std::vector<FrameMotion> motion = EstimateFrameMotion(frames, 0.1);
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(motion[i].known) << i;
    // Central differences over 1/15 s: ~2 % from the path's curvature.
    const Eigen::Vector3d truth_v = (Orbit(i / fps + 1e-5, rate).Inverse().translation -
                                     Orbit(i / fps - 1e-5, rate).Inverse().translation) / 2e-5;
    EXPECT_LT((motion[i].centre_velocity_m_s - truth_v).norm(), 0.04 * truth_v.norm()) << i;
    EXPECT_NEAR(motion[i].angular_velocity_rad_s.norm(), 1.0, 0.15) << i;
    // 4 ms later (the camera moved ~2 mm): its centre, and a point on the
    // board as the middle-row pose sees it moved (MoveForRow) against the
    // path's own pose then.
    const Rigid3& mid = frames[i].cam_from_world;
    const Rigid3 later = Orbit(i / fps + 0.004, rate);
    const Eigen::Vector3d centre = mid.Inverse().translation + motion[i].centre_velocity_m_s * 0.004;
    EXPECT_LT((centre - later.Inverse().translation).norm(), 1e-4);
    const Eigen::Vector3d board_point(0.05, -0.03, 0);
    Eigen::Vector3d moved;
    MoveForRow(mid.rotation.coeffs().data(), mid.translation.data(), board_point.data(), 0.004,
               motion[i].centre_velocity_m_s, motion[i].angular_velocity_rad_s, moved.data());
    EXPECT_LT(((mid * moved) - (later * board_point)).norm(), 1e-4);
  }
  EXPECT_FALSE(motion[5].known);
  EXPECT_FALSE(motion[6].known);
  EXPECT_FALSE(motion[7].known);
}

// Corners as a rolling-shutter camera on the orbit sees them: each corner's
// row time depends on where it lands, so the projection is iterated.
bool ProjectRolling(const Intrinsics& lens, double t_mid_s, double rate, double readout_s,
                    const Eigen::Vector3d& world, Eigen::Vector2d* px) {
  if (!Camera(lens, Orbit(t_mid_s, rate)).Project(world, px)) return false;
  for (int k = 0; k < 5; ++k) {
    const double t = t_mid_s + readout_s * ReadoutFraction(*px, lens.width, lens.height, 0);
    if (!Camera(lens, Orbit(t, rate)).Project(world, px)) return false;
  }
  return px->x() >= 0 && px->y() >= 0 && px->x() < lens.width && px->y() < lens.height;
}

struct RollingCase {
  BundleProblem problem;
  std::vector<Rigid3> truth;
  Intrinsics lens;
};

// 90 frames at 30 fps of the path at 1 rad/s (~0.4 m/s; phone L's pace on
// the demo is ~0.3 m/s), 10 ms readout (phones: 10-30 ms), 0.1 px noise;
// the lens starts 1 % long, the poses a few millimetres off.
RollingCase OrbitingBoard(double readout_s, int points = 0) {
  RollingCase c;
  BoardSpec spec;
  c.lens = Intrinsics::FromFov(480, 360, 1.0);
  c.problem.corners_world = CharucoCornersWorld(spec);
  Intrinsics start = c.lens;
  start.fx *= 1.01;
  start.fy *= 1.01;
  c.problem.devices["light"] = start;
  c.problem.square_pixels = true;  // fewer lens unknowns: a board-only lens is weakly determined
  c.problem.refine_tangential = false;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 0.1);
  const double rate = 1.0, fps = 30;
  for (int i = 0; i < 90; ++i) {
    const double t = i / fps;
    c.truth.push_back(Orbit(t, rate));
    BundleFrame f;
    f.device = "light";
    f.video = "light";
    f.time_s = t;
    f.posed = true;
    for (size_t k = 0; k < c.problem.corners_world.size(); ++k) {
      Eigen::Vector2d px;
      if (!ProjectRolling(c.lens, t, rate, readout_s, c.problem.corners_world[k], &px)) continue;
      f.corner_ids.push_back(static_cast<int>(k));
      f.corners_px.push_back(px + Eigen::Vector2d(noise(rng), noise(rng)));
    }
    f.cam_from_world = Rigid3(c.truth.back().rotation, c.truth.back().translation + Eigen::Vector3d(0.002, -0.001, 0.003));
    c.problem.frames.push_back(f);
  }
  // SfM points above the board (the object), seen by every frame they project into.
  std::uniform_real_distribution<double> box(-0.06, 0.06);
  for (int k = 0; k < points; ++k) {
    const Eigen::Vector3d x(box(rng), box(rng), 0.08 + box(rng));
    BundlePoint point;
    for (int i = 0; i < static_cast<int>(c.truth.size()); ++i) {
      Eigen::Vector2d px;
      if (ProjectRolling(c.lens, c.problem.frames[i].time_s, rate, readout_s, x, &px)) {
        point.observations.push_back({i, px + Eigen::Vector2d(noise(rng), noise(rng))});
      }
    }
    point.position_m = x + Eigen::Vector3d(0.002, 0.001, -0.002);
    c.problem.points.push_back(point);
  }
  return c;
}

double MedianCentreError(const BundleProblem& p, const std::vector<Rigid3>& truth) {
  std::vector<double> e;
  for (size_t i = 0; i < truth.size(); ++i) {
    e.push_back((p.frames[i].cam_from_world.Inverse().translation - truth[i].Inverse().translation).norm());
  }
  std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
  return e[e.size() / 2];
}

struct Solved {
  BundleStats stats;
  double focal_error = 0;     // fraction
  double centre_error_m = 0;  // median
};

Solved Solve(const RollingCase& c, bool model_rolling_shutter) {
  BundleOptions o;
  o.function_tolerance = 1e-10;
  o.max_iterations = 1000;
  o.rolling_shutter = model_rolling_shutter;
  BundleProblem p = c.problem;
  Solved s;
  s.stats = RefineBundle(&p, o);
  s.focal_error = p.devices["light"].fx / c.lens.fx - 1;
  s.centre_error_m = MedianCentreError(p, c.truth);
  return s;
}

// A 10 ms readout: modelled, the lens and poses come out as well as a
// global-shutter capture's with the same noise (this board-only problem's
// floor: ~0.3 % focal, ~1.5 mm); ignored, several times worse.
TEST(RollingShutterTest, BundleRecoversReadoutLensAndPoses) {
  const double readout = 0.010;
  const RollingCase rolling = OrbitingBoard(readout);
  const Solved modelled = Solve(rolling, true);
  const Solved ignored = Solve(rolling, false);
  const Solved floor = Solve(OrbitingBoard(0.0), false);
  std::printf("readout %.3f ms; focal error %+.3f %% modelled, %+.3f %% ignored, %+.3f %% global shutter; "
              "centres %.2f / %.2f / %.2f mm; corner RMS %.3f / %.3f / %.3f px\n",
              modelled.stats.readout_s.at("light") * 1e3, modelled.focal_error * 100, ignored.focal_error * 100,
              floor.focal_error * 100, modelled.centre_error_m * 1e3, ignored.centre_error_m * 1e3,
              floor.centre_error_m * 1e3, modelled.stats.corner_rms_px, ignored.stats.corner_rms_px,
              floor.stats.corner_rms_px);
  EXPECT_NEAR(modelled.stats.readout_s.at("light"), readout, 0.0005);
  EXPECT_EQ(modelled.stats.moving_frames.at("light"), 90);
  EXPECT_TRUE(ignored.stats.readout_s.empty());
  EXPECT_LT(std::abs(modelled.focal_error), std::abs(floor.focal_error) + 0.001);
  EXPECT_LT(modelled.centre_error_m, floor.centre_error_m + 0.5e-3);
  EXPECT_LT(modelled.stats.corner_rms_px, floor.stats.corner_rms_px + 0.005);
  EXPECT_GT(std::abs(ignored.focal_error), 2 * std::abs(modelled.focal_error));
  EXPECT_GT(ignored.centre_error_m, 2 * modelled.centre_error_m);
  EXPECT_GT(ignored.stats.corner_rms_px, modelled.stats.corner_rms_px + 0.01);
}

// The same with SfM points (the joint refinement): they see the readout too.
TEST(RollingShutterTest, BundleWithPointsRecoversReadout) {
  const double readout = 0.010;
  const RollingCase rolling = OrbitingBoard(readout, 200);
  const Solved modelled = Solve(rolling, true);
  const Solved ignored = Solve(rolling, false);
  std::printf("with points: readout %.3f ms; focal error %+.3f %% modelled, %+.3f %% ignored; centres %.2f / %.2f mm; "
              "point RMS %.3f / %.3f px\n", modelled.stats.readout_s.at("light") * 1e3, modelled.focal_error * 100,
              ignored.focal_error * 100, modelled.centre_error_m * 1e3, ignored.centre_error_m * 1e3,
              modelled.stats.point_rms_px, ignored.stats.point_rms_px);
  EXPECT_GT(modelled.stats.point_observations, 5000);
  EXPECT_NEAR(modelled.stats.readout_s.at("light"), readout, 0.0005);
  EXPECT_GT(ignored.centre_error_m, 2 * modelled.centre_error_m);
}

// A global-shutter video: the readout comes out near zero and the solution
// is the one without the model.
TEST(RollingShutterTest, GlobalShutterReadsZero) {
  const RollingCase global = OrbitingBoard(0.0);
  const Solved modelled = Solve(global, true);
  const Solved plain = Solve(global, false);
  EXPECT_LT(modelled.stats.readout_s.at("light"), 0.0003);
  EXPECT_NEAR(modelled.focal_error, plain.focal_error, 0.0005);
  EXPECT_NEAR(modelled.centre_error_m, plain.centre_error_m, 0.2e-3);
}

}  // namespace
}  // namespace relit::calib
