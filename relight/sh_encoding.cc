#include "relight/sh_encoding.h"

#include <cmath>

#include "core/error.h"

namespace relit::relight {

namespace {
constexpr double kPi = 3.14159265358979323846;
double Luminance(const Eigen::Vector3d& rgb) { return 0.2126 * rgb.x() + 0.7152 * rgb.y() + 0.0722 * rgb.z(); }
}  // namespace

std::array<double, kShCoefficientCount> ShBasis(const Eigen::Vector3d& d) {
  // Constants sqrt((2l+1)/(4 pi) (l-|m|)!/(l+|m|)!) (x sqrt 2 for m != 0),
  // written out for bands 0..2.
  const double x = d.x(), y = d.y(), z = d.z();
  return {0.28209479177387814,                          // 1 / (2 sqrt(pi))
          0.48860251190291992 * y,                      // sqrt(3 / (4 pi))
          0.48860251190291992 * z,
          0.48860251190291992 * x,
          1.0925484305920792 * x * y,                   // sqrt(15 / (4 pi))
          1.0925484305920792 * y * z,
          0.31539156525252005 * (3.0 * z * z - 1.0),    // sqrt(5 / (16 pi))
          1.0925484305920792 * x * z,
          0.54627421529603959 * (x * x - y * y)};       // sqrt(15 / (16 pi))
}

const std::vector<std::string>& ShLightChannelNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (int k = 0; k < kShCoefficientCount; ++k) n.push_back("shv" + std::to_string(k));
    for (int k = 0; k < kShCoefficientCount; ++k) n.push_back("shl" + std::to_string(k));
    for (const char* c : {"level.R", "level.G", "level.B"}) n.push_back(c);
    return n;
  }();
  return names;
}

ShProjection ProjectEnvironment(const render::EnvironmentLight& environment, int rows) {
  RELIT_REQUIRE(environment.valid() && rows >= 2, "SH projection: needs an environment map and rows >= 2");
  ShProjection p;
  for (auto& c : p.coefficients) c.setZero();
  const int cols = 2 * rows;
  const double d_theta = kPi / rows, d_phi = 2 * kPi / cols;
  for (int i = 0; i < rows; ++i) {
    const double theta = (i + 0.5) * d_theta;  // from +Z
    const double weight = std::sin(theta) * d_theta * d_phi;
    for (int j = 0; j < cols; ++j) {
      const double phi = (j + 0.5) * d_phi;
      const Eigen::Vector3d w(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      const Eigen::Vector3d radiance = environment.Eval(w.cast<float>()).cast<double>().matrix();
      const auto y = ShBasis(w);
      for (int k = 0; k < kShCoefficientCount; ++k) p.coefficients[k] += weight * y[k] * radiance;
      p.integral += weight * radiance;
    }
  }
  return p;
}

ShLight ShLight::FromCueLight(const CueLight& light) {
  ShLight s;
  s.kind = light.kind;
  s.color = light.color;
  switch (light.kind) {
    case CueLight::Kind::kPoint:
      s.position_m = light.position_m;
      break;
    case CueLight::Kind::kDirectional:
      RELIT_REQUIRE(light.direction_to_light.norm() > 0, "directional light without a direction");
      s.direction = light.direction_to_light.normalized();
      break;
    case CueLight::Kind::kEnvironment: {
      const ShProjection p = ProjectEnvironment(light.environment);
      const double total = Luminance(p.integral);
      RELIT_REQUIRE(total > 0, "sh input: the environment map is black");
      for (int k = 0; k < kShCoefficientCount; ++k) s.coefficients[k] = Luminance(p.coefficients[k]) / total;
      s.color = p.integral;
      break;
    }
    case CueLight::Kind::kQuad:
      Fail("the sh input (cues.input: sh) is defined for point, directional and environment lights only, not "
           "for area lights");
  }
  return s;
}

void ShLight::PixelFeatures(const Eigen::Vector3d& point_m, const Eigen::Vector3d& camera_centre_m,
                            float* out) const {
  const Eigen::Vector3d to_camera = camera_centre_m - point_m;
  const auto view = ShBasis(to_camera.normalized());
  std::array<double, kShCoefficientCount> light{};
  Eigen::Vector3d level = color;
  switch (kind) {
    case CueLight::Kind::kPoint: {
      const Eigen::Vector3d to_light = position_m - point_m;
      const double r2 = std::max(to_light.squaredNorm(), 1e-8);
      light = ShBasis(to_light / std::sqrt(r2));
      level = color / r2;  // inverse-square falloff: the network sees the absolute level
      break;
    }
    case CueLight::Kind::kDirectional:
      light = ShBasis(direction);
      break;
    default:
      light = coefficients;
      break;
  }
  for (int k = 0; k < kShCoefficientCount; ++k) {
    out[k] = static_cast<float>(view[k]);
    out[kShCoefficientCount + k] = static_cast<float>(light[k]);
  }
  for (int c = 0; c < 3; ++c) out[2 * kShCoefficientCount + c] = static_cast<float>(level[c]);
}

}  // namespace relit::relight
