#include "core/render/sampling.h"

#include <algorithm>

namespace relit::render {

Frame::Frame(const Vec3f& normal) : n(normal) {
  const float sign = std::copysign(1.0f, n.z());
  const float a = -1.0f / (sign + n.z());
  const float b = n.x() * n.y() * a;
  s = Vec3f(1.0f + sign * n.x() * n.x() * a, sign * b, -sign * n.x());
  t = Vec3f(b, sign + n.y() * n.y() * a, -n.y());
}

Vec3f SampleCosineHemisphere(const Vec2f& u) {
  // Concentric disk mapping (Shirley-Chiu) keeps strata compact.
  const float ox = 2.0f * u.x() - 1.0f, oy = 2.0f * u.y() - 1.0f;
  float r = 0, phi = 0;
  if (ox != 0 || oy != 0) {
    if (std::abs(ox) > std::abs(oy)) {
      r = ox;
      phi = (kPi / 4) * (oy / ox);
    } else {
      r = oy;
      phi = (kPi / 2) - (kPi / 4) * (ox / oy);
    }
  }
  const float x = r * std::cos(phi), y = r * std::sin(phi);
  return {x, y, std::sqrt(std::max(0.0f, 1.0f - x * x - y * y))};
}

Vec3f SampleUniformSphere(const Vec2f& u) {
  const float z = 1.0f - 2.0f * u.x();
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  const float phi = 2.0f * kPi * u.y();
  return {r * std::cos(phi), r * std::sin(phi), z};
}

Vec2f SampleUniformTriangle(const Vec2f& u) {
  const float su = std::sqrt(u.x());
  return {1.0f - su, u.y() * su};
}

Distribution1D::Distribution1D(const std::vector<float>& f) : func_(f), cdf_(f.size() + 1) {
  const int n = static_cast<int>(f.size());
  cdf_[0] = 0;
  for (int i = 0; i < n; ++i) cdf_[i + 1] = cdf_[i] + std::max(func_[i], 0.0f) / n;
  integral_ = cdf_[n];
  if (integral_ <= 0) {
    for (int i = 1; i <= n; ++i) cdf_[i] = static_cast<float>(i) / n;
  } else {
    for (int i = 1; i <= n; ++i) cdf_[i] /= integral_;
  }
}

float Distribution1D::SampleContinuous(float u, float* pdf, int* offset) const {
  const int n = size();
  // Last index with cdf <= u.
  const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u);
  const int index = std::clamp(static_cast<int>(it - cdf_.begin()) - 1, 0, n - 1);
  if (offset) *offset = index;
  float du = u - cdf_[index];
  const float width = cdf_[index + 1] - cdf_[index];
  if (width > 0) du /= width;
  if (pdf) *pdf = integral_ > 0 ? std::max(func_[index], 0.0f) / integral_ : 1.0f;
  return std::min((index + du) / n, 0x1.fffffep-1f);
}

Distribution2D::Distribution2D(const std::vector<float>& f, int width, int height) {
  std::vector<float> marginal(height);
  conditional_.reserve(height);
  for (int v = 0; v < height; ++v) {
    conditional_.emplace_back(std::vector<float>(f.begin() + static_cast<size_t>(v) * width,
                                                 f.begin() + static_cast<size_t>(v + 1) * width));
    marginal[v] = conditional_.back().integral();
  }
  marginal_ = Distribution1D(marginal);
}

Vec2f Distribution2D::Sample(const Vec2f& u, float* pdf) const {
  float pdf_v = 0, pdf_u = 0;
  int v_index = 0;
  const float v = marginal_.SampleContinuous(u.y(), &pdf_v, &v_index);
  const float uu = conditional_[v_index].SampleContinuous(u.x(), &pdf_u, nullptr);
  *pdf = pdf_u * pdf_v;
  return {uu, v};
}

float Distribution2D::Pdf(const Vec2f& uv) const {
  const int width = conditional_[0].size(), height = marginal_.size();
  const int iu = std::clamp(static_cast<int>(uv.x() * width), 0, width - 1);
  const int iv = std::clamp(static_cast<int>(uv.y() * height), 0, height - 1);
  if (marginal_.integral() <= 0) return 1.0f;
  return std::max(conditional_[iv].func(iu), 0.0f) / marginal_.integral();
}

}  // namespace relit::render
