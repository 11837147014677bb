#include "tools/synth/trajectory.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "core/error.h"

namespace relit::synth {

namespace {
constexpr double kTwoPi = 6.283185307179586;

uint64_t SplitMix64(uint64_t* state) {
  uint64_t z = (*state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}
}  // namespace

double UniformFromState(uint64_t* state) {
  return static_cast<double>(SplitMix64(state) >> 11) * 0x1.0p-53;
}

double NormalFromState(uint64_t* state) {
  const double u1 = 1.0 - UniformFromState(state);  // (0, 1]
  const double u2 = UniformFromState(state);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(kTwoPi * u2);
}

void HandheldPathParams::Check() const {
  RELIT_REQUIRE(distance_min_m > 0.05 && distance_min_m <= distance_max_m && distance_max_m < 10,
                "camera distance range must satisfy 0.05 < min <= max < 10 m, got [",
                distance_min_m, ", ", distance_max_m, "]");
  RELIT_REQUIRE(elevation_min_rad > 0 && elevation_min_rad <= elevation_max_rad &&
                    elevation_max_rad < 1.5,
                "camera elevation range must lie in the upper hemisphere (0, 86 deg), got [",
                elevation_min_rad, ", ", elevation_max_rad, "] rad");
  RELIT_REQUIRE(drift_period_s > 0, "drift period must be positive, got ", drift_period_s, " s");
  RELIT_REQUIRE(elevation_bands >= 1 && elevation_bands <= 8, "elevation bands must be in [1, 8], got ",
                elevation_bands);
  RELIT_REQUIRE(elevation_bands == 1 || band_period_s > 0,
                "more than one elevation band needs a positive band period, got ", band_period_s, " s");
  RELIT_REQUIRE(roll_max_rad >= 0 && roll_max_rad < 1.0, "roll_max must be in [0, 1) rad, got ",
                roll_max_rad);
  RELIT_REQUIRE(jitter_m >= 0 && jitter_m < 0.05, "jitter must be in [0, 0.05) m, got ", jitter_m);
  RELIT_REQUIRE(jitter_rad >= 0 && jitter_rad < 0.1, "rotation jitter must be in [0, 0.1) rad, got ",
                jitter_rad);
  RELIT_REQUIRE(aim_error_m >= 0 && aim_error_m < 0.2, "aim error must be in [0, 0.2) m, got ",
                aim_error_m);
}

double HandheldPath::Wave::Eval(double t_s) const {
  double sum = 0;
  for (size_t k = 0; k < amplitude.size(); ++k) {
    sum += amplitude[k] * std::sin(kTwoPi * frequency_hz[k] * t_s + phase_rad[k]);
  }
  return sum;
}

HandheldPath::Wave HandheldPath::MakeWave(uint64_t* state, double base_frequency_hz,
                                          int terms) const {
  Wave wave;
  double total = 0;
  for (int k = 0; k < terms; ++k) {
    // Roughly harmonic but detuned so the sum does not repeat quickly.
    wave.frequency_hz.push_back(base_frequency_hz * (k + 1) * (0.8 + 0.45 * UniformFromState(state)));
    wave.phase_rad.push_back(kTwoPi * UniformFromState(state));
    // Lower frequencies carry more of the motion.
    const double a = (0.5 + UniformFromState(state)) / (k + 1);
    wave.amplitude.push_back(a);
    total += a;
  }
  for (double& a : wave.amplitude) a /= total;  // sum |a_k| = 1: |Eval| <= 1
  return wave;
}

HandheldPath::HandheldPath(const HandheldPathParams& params, uint64_t seed) : params_(params) {
  params_.Check();
  uint64_t state = seed * 0x2545f4914f6cdd1dULL + 0x1234567;
  azimuth0_rad_ = kTwoPi * UniformFromState(&state);
  const double drift_hz = 1.0 / params_.drift_period_s;
  azimuth_wobble_ = MakeWave(&state, drift_hz, 2);
  elevation_ = MakeWave(&state, drift_hz, 3);
  distance_ = MakeWave(&state, drift_hz, 3);
  roll_ = MakeWave(&state, drift_hz, 2);
  for (int i = 0; i < 3; ++i) {
    jitter_position_[i] = MakeWave(&state, 1.5, 3);  // hand shake, ~1.5-6 Hz
    jitter_rotation_[i] = MakeWave(&state, 1.5, 3);
    aim_[i] = MakeWave(&state, drift_hz * 1.5, 2);
  }
}

double HandheldPath::AzimuthRad(double t_s) const {
  // The wobble's rate (at most 25% of the mean rate) never reverses the motion.
  double max_frequency_hz = 0;
  for (double f : azimuth_wobble_.frequency_hz) max_frequency_hz = std::max(max_frequency_hz, f);
  const double mean_rate_rad_per_s = kTwoPi * params_.azimuth_rate_rev_per_s;
  const double wobble_amplitude_rad =
      0.25 * std::abs(mean_rate_rad_per_s) / (kTwoPi * max_frequency_hz);
  return azimuth0_rad_ + mean_rate_rad_per_s * t_s + wobble_amplitude_rad * azimuth_wobble_.Eval(t_s);
}

double HandheldPath::ElevationRad(double t_s) const {
  const int bands = params_.elevation_bands;
  const double band_rad = (params_.elevation_max_rad - params_.elevation_min_rad) / bands;
  // Which band, as a continuous index: steps of 1 at each band's end, each
  // a smoothstep over a fifth of a band period (the hand rising to the
  // next ring), clamped to the first and last band outside the video.
  double band = 0;
  if (bands > 1) {
    const double u = t_s / params_.band_period_s;
    constexpr double kRise = 0.2;
    for (int k = 1; k < bands; ++k) {
      const double x = std::clamp((u - k) / kRise + 0.5, 0.0, 1.0);
      band += x * x * (3 - 2 * x);
    }
  }
  // Within a band the drift keeps a tenth of the band's width clear of its
  // edges, so neighbouring bands do not blur into one.
  const double mid = params_.elevation_min_rad + (band + 0.5) * band_rad;
  const double half = (bands > 1 ? 0.4 : 0.5) * band_rad;
  return mid + half * elevation_.Eval(t_s);
}

double HandheldPath::DistanceM(double t_s) const {
  const double mid = 0.5 * (params_.distance_min_m + params_.distance_max_m);
  const double half = 0.5 * (params_.distance_max_m - params_.distance_min_m);
  return mid + half * distance_.Eval(t_s);
}

double HandheldPath::RollRad(double t_s) const { return params_.roll_max_rad * roll_.Eval(t_s); }

Rigid3 HandheldPath::CamFromWorld(double t_s) const {
  const double azimuth = AzimuthRad(t_s), elevation = ElevationRad(t_s);
  const double distance = DistanceM(t_s);
  const Eigen::Vector3d direction(std::cos(elevation) * std::cos(azimuth),
                                  std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
  // Jitter is scaled so the distance and elevation bounds still hold.
  Eigen::Vector3d shake(jitter_position_[0].Eval(t_s), jitter_position_[1].Eval(t_s),
                        jitter_position_[2].Eval(t_s));
  shake -= shake.dot(direction) * direction;  // tangential only: keeps the distance exact
  const Eigen::Vector3d centre =
      params_.target_world + distance * direction + params_.jitter_m * shake / std::sqrt(3.0);
  const Eigen::Vector3d aim =
      params_.target_world + params_.aim_error_m * Eigen::Vector3d(aim_[0].Eval(t_s),
                                                                   aim_[1].Eval(t_s),
                                                                   0.5 * aim_[2].Eval(t_s)) /
                                 std::sqrt(2.25);
  const Rigid3 look = LookAt(centre, aim, Eigen::Vector3d::UnitZ());
  const Eigen::Vector3d shake_rad(jitter_rotation_[0].Eval(t_s), jitter_rotation_[1].Eval(t_s),
                                  jitter_rotation_[2].Eval(t_s));
  const Eigen::Vector3d jitter_axis_angle = params_.jitter_rad * shake_rad / std::sqrt(3.0);
  Eigen::Quaterniond jitter = Eigen::Quaterniond::Identity();
  if (jitter_axis_angle.norm() > 0) {
    jitter = Eigen::AngleAxisd(jitter_axis_angle.norm(), jitter_axis_angle.normalized());
  }
  // Roll and shake act in the camera frame, i.e. before the world->camera map.
  const Eigen::Quaterniond roll(Eigen::AngleAxisd(RollRad(t_s), Eigen::Vector3d::UnitZ()));
  const Eigen::Quaterniond rotation = roll * jitter * look.rotation;
  return Rigid3(rotation, -(rotation * centre));
}

Eigen::Vector3d HandheldPath::CentreWorld(double t_s) const {
  return CamFromWorld(t_s).Inverse().translation;
}

}  // namespace relit::synth
