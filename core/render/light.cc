#include "core/render/light.h"

#include <algorithm>
#include <cmath>

#include "core/color.h"
#include "core/error.h"

namespace relit::render {

EnvironmentLight::EnvironmentLight(const Image& map, float scale, float rotation_z_rad)
    : scale_(scale), rotation_z_rad_(rotation_z_rad) {
  RELIT_REQUIRE(map.channels() >= 3 && map.width() >= 2 && map.height() >= 2,
                "environment map must be RGB and at least 2x2, got ", map.width(), "x",
                map.height(), "x", map.channels());
  auto rgb = std::make_shared<Image>(map.SelectChannels(std::vector<int>{0, 1, 2}));
  // Sampling density: luminance x sin(theta) (the equirect area element).
  // A small floor keeps every texel with light reachable by sampling.
  std::vector<float> f(rgb->pixel_count());
  double mean = 0;
  for (int y = 0; y < rgb->height(); ++y) {
    const float sin_theta = std::sin(kPi * (y + 0.5f) / rgb->height());
    for (int x = 0; x < rgb->width(); ++x) {
      const float* px = rgb->pixel(x, y);
      for (int c = 0; c < 3; ++c) {
        RELIT_REQUIRE(std::isfinite(px[c]) && px[c] >= 0,
                      "environment map has a negative or non-finite value at pixel (", x, ", ", y, ")");
      }
      f[static_cast<size_t>(y) * rgb->width() + x] = Luminance(px[0], px[1], px[2]) * sin_theta;
      mean += f.back() / f.size();
    }
  }
  for (size_t i = 0; i < f.size(); ++i) {
    const float* px = &rgb->data()[i * 3];
    if (px[0] + px[1] + px[2] > 0) f[i] = std::max(f[i], static_cast<float>(1e-4 * mean));
  }
  distribution_ = Distribution2D(f, rgb->width(), rgb->height());
  map_ = rgb;
}

EnvironmentLight EnvironmentLight::FromFile(const std::string& path, float scale,
                                            float rotation_z_rad) {
  return EnvironmentLight(ReadImage(path), scale, rotation_z_rad);
}

Vec2f EnvironmentLight::DirectionToUv(const Vec3f& d) {
  // atan2 keeps precision near the poles, where acos(z) does not.
  const float theta = std::atan2(std::sqrt(d.x() * d.x() + d.y() * d.y()), d.z());
  float phi = std::atan2(d.y(), d.x());
  if (phi < 0) phi += 2.0f * kPi;
  return {std::min(phi / (2.0f * kPi), 0x1.fffffep-1f), theta / kPi};
}

Vec3f EnvironmentLight::UvToDirection(const Vec2f& uv) {
  const float theta = uv.y() * kPi, phi = uv.x() * 2.0f * kPi;
  const float s = std::sin(theta);
  return {s * std::cos(phi), s * std::sin(phi), std::cos(theta)};
}

namespace {
Vec3f RotateZ(const Vec3f& d, float angle) {
  const float c = std::cos(angle), s = std::sin(angle);
  return {c * d.x() - s * d.y(), s * d.x() + c * d.y(), d.z()};
}
}  // namespace

Rgb EnvironmentLight::Eval(const Vec3f& direction_world) const {
  // Piecewise constant, exactly the density that Sample() draws from.
  const Vec2f uv = DirectionToUv(RotateZ(direction_world, -rotation_z_rad_));
  const int x = std::clamp(static_cast<int>(uv.x() * map_->width()), 0, map_->width() - 1);
  const int y = std::clamp(static_cast<int>(uv.y() * map_->height()), 0, map_->height() - 1);
  const float* px = map_->pixel(x, y);
  return Rgb(px[0], px[1], px[2]) * scale_;
}

Vec3f EnvironmentLight::Sample(const Vec2f& u, float* pdf) const {
  float pdf_uv = 0;
  const Vec2f uv = distribution_.Sample(u, &pdf_uv);
  const float sin_theta = std::sin(uv.y() * kPi);
  const Vec3f d = RotateZ(UvToDirection(uv), rotation_z_rad_);
  *pdf = sin_theta > 0 ? pdf_uv / (2.0f * kPi * kPi * sin_theta) : 0.0f;
  return d;
}

float EnvironmentLight::Pdf(const Vec3f& direction_world) const {
  const Vec2f uv = DirectionToUv(RotateZ(direction_world, -rotation_z_rad_));
  const float sin_theta = std::sin(uv.y() * kPi);
  if (sin_theta <= 0) return 0;
  return distribution_.Pdf(uv) / (2.0f * kPi * kPi * sin_theta);
}

}  // namespace relit::render
