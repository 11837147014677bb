// Smooth hand-held camera paths around an object (relit-synth).
//
// A path is a function of continuous time t (seconds on the common clock, see
// docs/synthetic.md). The phone circles the target in azimuth at a steady
// mean rate while elevation, distance and roll drift through sums of a few
// low-frequency sinusoids; small higher-frequency "jitter" in position and
// orientation and a slowly wandering aim point make it look hand-held.
// All sinusoids are periodic, so a path is defined (and stays within its
// bounds) for any t, also before 0 or after the nominal duration.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/camera.h"

namespace relit::synth {

struct HandheldPathParams {
  Eigen::Vector3d target_world = Eigen::Vector3d::Zero();  // what the phone aims at, metres
  double distance_min_m = 0.3;   // camera centre to target
  double distance_max_m = 0.7;
  double elevation_min_rad = 0.26;  // above the horizontal plane through the target
  double elevation_max_rad = 1.22;
  // Mean azimuth rate in revolutions per second (sign = direction of travel).
  double azimuth_rate_rev_per_s = 0.05;
  // Period of the slow drift of elevation/distance/roll, seconds.
  double drift_period_s = 10.0;
  // Elevation bands, lowest first, as a capture guide asks for (one ring
  // low, one high): the elevation range splits into this many equal bands
  // and the phone spends band_period_s in each, drifting only within it,
  // then rises to the next over a fifth of that time. 1: one drift over
  // the whole range.
  int elevation_bands = 1;
  double band_period_s = 0;  // > 0 with more than one band
  double roll_max_rad = 0.17;     // |roll| about the optical axis stays below this
  double jitter_m = 0.0015;       // hand-shake amplitude, position
  double jitter_rad = 0.005;      // hand-shake amplitude, orientation
  double aim_error_m = 0.01;      // wander of the aim point around the target

  void Check() const;  // throws relit::Error for inconsistent ranges
};

class HandheldPath {
 public:
  HandheldPath(const HandheldPathParams& params, uint64_t seed);

  // Pose at common time t_s.
  Rigid3 CamFromWorld(double t_s) const;
  // Camera centre in world at t_s (same as CamFromWorld(t).Inverse().translation).
  Eigen::Vector3d CentreWorld(double t_s) const;
  // Smooth (jitter-free) spherical coordinates around the target.
  double AzimuthRad(double t_s) const;
  double ElevationRad(double t_s) const;
  double DistanceM(double t_s) const;
  double RollRad(double t_s) const;

  const HandheldPathParams& params() const { return params_; }

 private:
  // sum_k a_k sin(2 pi f_k t + phase_k), with sum |a_k| <= 1.
  struct Wave {
    std::vector<double> amplitude, frequency_hz, phase_rad;
    double Eval(double t_s) const;
  };
  Wave MakeWave(uint64_t* state, double base_frequency_hz, int terms) const;

  HandheldPathParams params_;
  double azimuth0_rad_ = 0;
  Wave azimuth_wobble_, elevation_, distance_, roll_;
  Wave jitter_position_[3], jitter_rotation_[3], aim_[3];
};

// A uniform random number in [0, 1) from a splitmix64 state (portable and
// deterministic across compilers, unlike <random> distributions).
double UniformFromState(uint64_t* state);
// Standard normal variate (Box-Muller) from the same kind of state.
double NormalFromState(uint64_t* state);

}  // namespace relit::synth
