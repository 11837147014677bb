// Random numbers and sampling helpers for the path tracer.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace relit::render {

using Vec2f = Eigen::Vector2f;
using Vec3f = Eigen::Vector3f;
using Rgb = Eigen::Array3f;  // linear RGB radiance / reflectance

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInvPi = 1.0f / kPi;

// PCG32 (O'Neill 2014): small state, good statistics, deterministic streams.
class Rng {
 public:
  Rng(uint64_t seed = 0, uint64_t stream = 0) { Seed(seed, stream); }
  void Seed(uint64_t seed, uint64_t stream) {
    state_ = 0;
    inc_ = (stream << 1u) | 1u;
    Next();
    state_ += seed;
    Next();
  }
  uint32_t Next() {
    const uint64_t old = state_;
    state_ = old * 6364136223846793005ULL + inc_;
    const uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
    const uint32_t rot = static_cast<uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31));
  }
  // Uniform in [0, 1).
  float Uniform() { return std::fmin(static_cast<float>(Next()) * 0x1p-32f, 0x1.fffffep-1f); }
  Vec2f Uniform2() { const float a = Uniform(); return {a, Uniform()}; }

 private:
  uint64_t state_ = 0, inc_ = 1;
};

// 64-bit mix (splitmix64 finaliser) to derive independent seeds per pixel.
inline uint64_t MixBits(uint64_t v) {
  v ^= v >> 31;
  v *= 0x7fb5d329728ea185ULL;
  v ^= v >> 27;
  v *= 0x81dadef4bc2dd44dULL;
  v ^= v >> 33;
  return v;
}

// Orthonormal basis around a unit normal (Duff et al. 2017).
struct Frame {
  Vec3f s, t, n;
  Frame() = default;
  explicit Frame(const Vec3f& normal);
  Vec3f ToLocal(const Vec3f& v) const { return {v.dot(s), v.dot(t), v.dot(n)}; }
  Vec3f ToWorld(const Vec3f& v) const { return s * v.x() + t * v.y() + n * v.z(); }
};

Vec3f SampleCosineHemisphere(const Vec2f& u);  // local frame, pdf = cos/pi
Vec3f SampleUniformSphere(const Vec2f& u);      // pdf = 1/(4 pi)
// Uniform point on a triangle, barycentric (b1, b2).
Vec2f SampleUniformTriangle(const Vec2f& u);

inline float PowerHeuristic(float pdf_a, float pdf_b) {
  const float a = pdf_a * pdf_a, b = pdf_b * pdf_b;
  return a + b > 0 ? a / (a + b) : 0.0f;
}

// Piecewise-constant 1-D and 2-D distributions (pbrt-v3 style) for
// importance sampling tabulated functions such as environment maps.
class Distribution1D {
 public:
  Distribution1D() = default;
  explicit Distribution1D(const std::vector<float>& f);
  // Continuous sample in [0, 1); returns pdf w.r.t. [0, 1) and the bin.
  float SampleContinuous(float u, float* pdf, int* offset) const;
  int size() const { return static_cast<int>(func_.size()); }
  float integral() const { return integral_; }
  float func(int i) const { return func_[i]; }

 private:
  std::vector<float> func_, cdf_;
  float integral_ = 0;
};

class Distribution2D {
 public:
  Distribution2D() = default;
  // f is width*height, row-major, rows = v.
  Distribution2D(const std::vector<float>& f, int width, int height);
  // Sample (u, v) in [0,1)^2 with pdf w.r.t. area in [0,1)^2.
  Vec2f Sample(const Vec2f& u, float* pdf) const;
  float Pdf(const Vec2f& uv) const;

 private:
  std::vector<Distribution1D> conditional_;
  Distribution1D marginal_;
};

}  // namespace relit::render
