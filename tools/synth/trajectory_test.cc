#include "tools/synth/trajectory.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "tools/synth/capture_plan.h"
#include "tools/synth/scene.h"

namespace relit::synth {
namespace {

HandheldPathParams Params() {
  HandheldPathParams p;
  p.target_world = Eigen::Vector3d(0, 0, 0.03);
  p.azimuth_rate_rev_per_s = 1.0 / 10.0;
  p.drift_period_s = 10.0;
  return p;
}

TEST(Trajectory, StaysInDistanceRangeAndUpperHemisphere) {
  const HandheldPathParams p = Params();
  for (uint64_t seed = 0; seed < 20; ++seed) {
    const HandheldPath path(p, seed);
    double min_d = 1e9, max_d = 0;
    for (double t = -5; t < 25; t += 0.05) {
      const Eigen::Vector3d centre = path.CentreWorld(t);
      const double d = (centre - p.target_world).norm();
      min_d = std::min(min_d, d);
      max_d = std::max(max_d, d);
      EXPECT_GE(d, p.distance_min_m - 1e-4) << "seed " << seed << " t " << t;
      EXPECT_LE(d, p.distance_max_m + 1e-4) << "seed " << seed << " t " << t;
      const double elevation = std::asin((centre - p.target_world).z() / d);
      EXPECT_GE(elevation, p.elevation_min_rad - 0.01);
      EXPECT_LE(elevation, p.elevation_max_rad + 0.01);
      EXPECT_GT(centre.z(), 0.05);  // well above the table
      // The camera looks roughly at the target (aim error is centimetres).
      const Rigid3 pose = path.CamFromWorld(t);
      const Eigen::Vector3d target_cam = pose * p.target_world;
      EXPECT_GT(target_cam.z(), 0);
      EXPECT_LT(std::hypot(target_cam.x(), target_cam.y()) / target_cam.z(), 0.15);
      // Roll stays within its bound.
      EXPECT_LE(std::abs(path.RollRad(t)), p.roll_max_rad + 1e-12);
    }
    // Height and distance actually vary (not a fixed circle).
    EXPECT_GT(max_d - min_d, 0.1) << "seed " << seed;
  }
}

TEST(Trajectory, IsSmooth) {
  const HandheldPath path(Params(), 3);
  const double dt = 1.0 / 30;
  for (double t = 0; t < 10; t += dt) {
    const double step_m = (path.CentreWorld(t + dt) - path.CentreWorld(t)).norm();
    EXPECT_LT(step_m, 0.03) << t;  // < 0.9 m/s
    EXPECT_LT(RotationAngle(path.CamFromWorld(t + dt).rotation, path.CamFromWorld(t).rotation), 0.1);
  }
}

// Two rings, each a whole turn: every azimuth is filmed from both the lower
// and the upper half of the elevation range, and the rise between them is
// smooth and stays within the range.
TEST(Trajectory, ElevationBandsFilmEveryAzimuthLowAndHigh) {
  HandheldPathParams p = Params();
  p.azimuth_rate_rev_per_s = 2.0 / 10.0;  // two turns in 10 s
  p.elevation_bands = 2;
  p.band_period_s = 5.0;
  const double middle = 0.5 * (p.elevation_min_rad + p.elevation_max_rad);
  for (uint64_t seed = 0; seed < 10; ++seed) {
    const HandheldPath path(p, seed);
    for (double t = 0; t < 10; t += 0.05) {
      const double elevation = path.ElevationRad(t);
      EXPECT_GE(elevation, p.elevation_min_rad - 1e-9) << "seed " << seed << " t " << t;
      EXPECT_LE(elevation, p.elevation_max_rad + 1e-9) << "seed " << seed << " t " << t;
      // Away from the rise (a fifth of a band around t = 5 s): in its ring.
      if (t < 4.5) {
        EXPECT_LT(elevation, middle) << "seed " << seed << " t " << t;
      }
      if (t > 5.5) {
        EXPECT_GT(elevation, middle) << "seed " << seed << " t " << t;
      }
      EXPECT_LT(std::abs(path.ElevationRad(t + 1.0 / 30) - elevation), 0.04) << "seed " << seed << " t " << t;
    }
  }
  p.band_period_s = 0;
  EXPECT_THROW(p.Check(), Error);
}

TEST(Trajectory, AzimuthAdvancesMonotonically) {
  const HandheldPath path(Params(), 5);
  for (double t = 0; t < 20; t += 0.01) EXPECT_GT(path.AzimuthRad(t + 0.01), path.AzimuthRad(t));
  EXPECT_NEAR(path.AzimuthRad(10) - path.AzimuthRad(0), 2 * M_PI, 0.6);
}

TEST(Trajectory, DeterministicPerSeed) {
  const HandheldPath a(Params(), 11), b(Params(), 11), c(Params(), 12);
  EXPECT_EQ(a.CamFromWorld(1.23).ToMatrix(), b.CamFromWorld(1.23).ToMatrix());
  EXPECT_NE(a.CamFromWorld(1.23).ToMatrix(), c.CamFromWorld(1.23).ToMatrix());
}

TEST(Trajectory, RejectsBadRanges) {
  HandheldPathParams p = Params();
  p.distance_min_m = 0.8;
  EXPECT_THROW(HandheldPath(p, 1), std::runtime_error);
  p = Params();
  p.elevation_min_rad = -0.1;
  EXPECT_THROW(HandheldPath(p, 1), std::runtime_error);
}

// Total azimuth travelled (unwrapped) by a camera path around the target.
double AzimuthTravelled(const VideoPlan& video, const Eigen::Vector3d& target) {
  double total = 0, previous = 0;
  for (size_t i = 0; i < video.frames.size(); ++i) {
    const Eigen::Vector3d c = video.frames[i].cam_from_world.Inverse().translation - target;
    const double azimuth = std::atan2(c.y(), c.x());
    if (i > 0) total += std::abs(std::remainder(azimuth - previous, 2 * M_PI));
    previous = azimuth;
  }
  return total;
}

TEST(CapturePlan, PhoneLMovesAboutThreeTimesFasterAndCarriesTheFlash) {
  SynthOptions options = SynthOptions::ForSize("demo");
  options.out = "unused";
  SynthScene scene;  // planning only needs the target
  scene.target_world = Eigen::Vector3d(0, 0, 0.03);
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    options.seed = seed;
    const CapturePlan plan = MakeCapturePlan(options, scene);
    const double view_rad = AzimuthTravelled(plan.view, scene.target_world);
    const double light_rad = AzimuthTravelled(plan.light, scene.target_world);
    EXPECT_NEAR(view_rad, 2 * M_PI * options.view_turns, 1.0);
    EXPECT_GT(light_rad / view_rad, 2.3) << "seed " << seed;
    EXPECT_LT(light_rad / view_rad, 3.7) << "seed " << seed;
    // Light frames: the flash sits at the configured offset from phone L's lens.
    for (const FramePlan& f : plan.light.frames) {
      EXPECT_NEAR((f.cam_from_world * f.light_position_world - Eigen::Vector3d(0.01, 0, 0)).norm(), 0,
                  1e-9);
    }
    // Phone V frames see the flash of phone L at the same common time.
    const double offset = plan.light_start_offset_s;
    EXPECT_GE(std::abs(offset), options.audio_offset_min_s);
    EXPECT_LE(std::abs(offset), options.audio_offset_max_s);
    for (const FramePlan& v : plan.view.frames) {
      EXPECT_DOUBLE_EQ(v.t_common_s, v.t_own_s);
      // Phone V frames are lit by phone L's flash somewhere on its path.
      const double d = (v.light_position_world - scene.target_world).norm();
      EXPECT_GT(d, options.distance_min_m - 0.02);
      EXPECT_LT(d, options.distance_max_m + 0.02);
    }
    EXPECT_NEAR(plan.light.frames[5].t_common_s, 5.0 / options.LightFps() + offset, 1e-12);
    // View and light directions are not correlated: the angle between the
    // two phones (seen from the object) takes many values.
    double min_angle = M_PI, max_angle = 0;
    for (const FramePlan& v : plan.view.frames) {
      const Eigen::Vector3d a = (v.cam_from_world.Inverse().translation - scene.target_world).normalized();
      const Eigen::Vector3d b = (v.light_position_world - scene.target_world).normalized();
      const double angle = std::acos(std::clamp(a.dot(b), -1.0, 1.0));
      min_angle = std::min(min_angle, angle);
      max_angle = std::max(max_angle, angle);
    }
    EXPECT_LT(min_angle, 0.6) << "seed " << seed;
    EXPECT_GT(max_angle, 1.8) << "seed " << seed;
  }
}

// Phone L with its own frame count, 29.97 fps and audio rate (issue 25).
TEST(CapturePlan, PhoneLHasItsOwnFrameCountAndRate) {
  SynthOptions options = SynthOptions::ForSize("tiny");
  options.out = "unused";
  options.light_frames_per_video = 37;
  options.light_fps = 29.97;
  options.light_audio_rate_hz = 44100;
  EXPECT_DOUBLE_EQ(options.LightFps(), 30000.0 / 1001);
  EXPECT_DOUBLE_EQ(SynthOptions::ExactFps(30.0), 30.0);
  EXPECT_DOUBLE_EQ(SynthOptions::ExactFps(59.94), 60000.0 / 1001);
  EXPECT_DOUBLE_EQ(SynthOptions::ExactFps(25.0), 25.0);
  SynthScene scene;
  const CapturePlan plan = MakeCapturePlan(options, scene);
  ASSERT_EQ(plan.light.frames.size(), 37u);
  ASSERT_EQ(plan.view.frames.size(), 30u);
  EXPECT_EQ(plan.light.audio_rate_hz, 44100);
  EXPECT_EQ(plan.view.audio_rate_hz, 48000);
  EXPECT_NEAR(plan.light.frames[30].t_own_s, 30 * 1001.0 / 30000, 1e-12);
  EXPECT_NEAR(plan.light.frames[30].t_common_s,
              30 * 1001.0 / 30000 + plan.light_start_offset_s, 1e-12);
  EXPECT_NEAR(plan.view.frames[29].t_own_s, 29 / 30.0, 1e-12);
}

// Interpolation views lie on phone V's path where phone L records too (the
// frames relit-capture keeps), for offsets of both signs; the demo's usable
// span covers most of its turn.
TEST(CapturePlan, InterpolationViewsLieWhereBothPhonesRecord) {
  for (const char* size : {"tiny", "demo"}) {
    SynthOptions options = SynthOptions::ForSize(size);
    options.out = "unused";
    options.eval_interpolation_views = 12;
    SynthScene scene;
    scene.target_world = Eigen::Vector3d(0, 0, 0.03);
    for (uint64_t seed = 1; seed <= 4; ++seed) {
      options.seed = seed;
      const CapturePlan plan = MakeCapturePlan(options, scene);
      const double begin_s = std::max(plan.view.frames.front().t_common_s, plan.light.frames.front().t_common_s);
      const double end_s = std::min(plan.view.frames.back().t_common_s, plan.light.frames.back().t_common_s);
      if (std::string(size) == "demo") {
        EXPECT_GT(end_s - begin_s, 0.85 * options.duration_s()) << "seed " << seed;
      }
      for (const EvalView& view : plan.eval_views) {
        if (view.set != "interpolation") continue;
        const Eigen::Vector3d centre = view.cam_from_world.Inverse().translation;
        const FramePlan* nearest = nullptr;
        for (const FramePlan& f : plan.view.frames) {
          if (!nearest || (f.cam_from_world.Inverse().translation - centre).norm() <
                              (nearest->cam_from_world.Inverse().translation - centre).norm()) {
            nearest = &f;
          }
        }
        const double frame_s = 1.0 / options.fps;
        EXPECT_GE(nearest->t_common_s, begin_s - frame_s) << size << " seed " << seed << " " << view.name;
        EXPECT_LE(nearest->t_common_s, end_s + frame_s) << size << " seed " << seed << " " << view.name;
      }
    }
  }
}

// The tiny preset's phones differ in size; a rolling shutter reads rows
// over its readout with the middle row at the frame's time; the exposure
// drifts within its amplitude (issue 25).
TEST(CapturePlan, RollingShutterBandsSizesAndExposureDrift) {
  SynthOptions options = SynthOptions::ForSize("tiny");
  options.out = "unused";
  options.light_rolling_shutter_s = 0.02;
  options.light_exposure_drift = 0.2;
  SynthScene scene;
  const CapturePlan plan = MakeCapturePlan(options, scene);
  EXPECT_EQ(plan.light_intrinsics.width, 352);
  EXPECT_EQ(plan.light_intrinsics.height, 264);
  EXPECT_EQ(plan.view_intrinsics.width, 320);
  EXPECT_NEAR(plan.light.audio_start_s, 0.034, 1e-12);
  double low = 2, high = 0;
  for (const FramePlan& frame : plan.light.frames) {
    ASSERT_EQ(frame.bands.size(), static_cast<size_t>(kRollingShutterBands));
    EXPECT_EQ(frame.bands.front().row_begin, 0);
    EXPECT_EQ(frame.bands.back().row_end, 264);
    for (size_t b = 1; b < frame.bands.size(); ++b) {
      EXPECT_EQ(frame.bands[b].row_begin, frame.bands[b - 1].row_end);
      EXPECT_GT(frame.bands[b].t_common_s, frame.bands[b - 1].t_common_s);
    }
    // Each band at its middle row's time; row 0 half a readout before the frame time.
    for (const RowBand& band : frame.bands) {
      const double middle_row = 0.5 * (band.row_begin + band.row_end);
      EXPECT_NEAR(band.t_common_s, frame.t_common_s + (middle_row / 264 - 0.5) * 0.02, 1e-12);
    }
    EXPECT_NEAR(frame.bands.front().t_common_s, frame.t_common_s - 0.01, 0.02 / kRollingShutterBands);
    // The flash moves with phone L within the readout.
    EXPECT_GT((frame.bands.back().light_position_world - frame.bands.front().light_position_world).norm(), 1e-4);
    low = std::min(low, frame.exposure_scale);
    high = std::max(high, frame.exposure_scale);
  }
  EXPECT_GE(low, 0.8 - 1e-12);
  EXPECT_LE(high, 1.2 + 1e-12);
  EXPECT_GT(high - low, 0.2);  // 33 frames over one period
  for (const FramePlan& frame : plan.view.frames) EXPECT_EQ(frame.exposure_scale, 1.0);
  options.light_rolling_shutter_s = 0.05;  // longer than a 29.97 fps frame
  EXPECT_THROW(CheckOptions(options), std::runtime_error);
}

}  // namespace
}  // namespace relit::synth
