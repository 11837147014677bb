#include "core/render/sampling.h"

#include <gtest/gtest.h>

namespace relit::render {
namespace {

TEST(Rng, DeterministicAndUniform) {
  Rng a(42, 7), b(42, 7), c(43, 7);
  double sum = 0;
  bool differs = false;
  for (int i = 0; i < 100000; ++i) {
    const float x = a.Uniform();
    ASSERT_EQ(x, b.Uniform());
    differs |= x != c.Uniform();
    ASSERT_GE(x, 0.0f);
    ASSERT_LT(x, 1.0f);
    sum += x;
  }
  EXPECT_TRUE(differs);
  EXPECT_NEAR(sum / 100000, 0.5, 0.005);
}

TEST(Frame, IsOrthonormal) {
  Rng rng(1, 2);
  for (int i = 0; i < 1000; ++i) {
    const Vec3f n = SampleUniformSphere(rng.Uniform2());
    const Frame f(n);
    EXPECT_NEAR(f.s.dot(f.t), 0, 1e-5);
    EXPECT_NEAR(f.s.dot(f.n), 0, 1e-5);
    EXPECT_NEAR(f.s.norm(), 1, 1e-5);
    EXPECT_NEAR((f.ToWorld(f.ToLocal(Vec3f(0.3f, -0.2f, 0.9f))) - Vec3f(0.3f, -0.2f, 0.9f)).norm(), 0, 1e-5);
  }
}

TEST(Distribution2D, SamplesProportionallyAndPdfMatches) {
  const int w = 8, h = 4;
  std::vector<float> f(w * h);
  for (int i = 0; i < w * h; ++i) f[i] = static_cast<float>((i * 7) % 5);
  const Distribution2D d(f, w, h);
  double total = 0;
  for (float v : f) total += v;
  std::vector<int> counts(w * h, 0);
  Rng rng(5, 5);
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    float pdf = 0;
    const Vec2f uv = d.Sample(rng.Uniform2(), &pdf);
    const int x = static_cast<int>(uv.x() * w), y = static_cast<int>(uv.y() * h);
    ASSERT_GT(f[y * w + x], 0) << "sampled a zero bin";
    ASSERT_NEAR(pdf, d.Pdf(uv), 1e-4f);
    ASSERT_NEAR(pdf, f[y * w + x] / (total / (w * h)), 1e-4f);
    ++counts[y * w + x];
  }
  for (int i = 0; i < w * h; ++i) {
    const double expected = n * f[i] / total;
    EXPECT_NEAR(counts[i], expected, 5 * std::sqrt(expected) + 1);
  }
}

}  // namespace
}  // namespace relit::render
