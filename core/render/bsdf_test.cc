#include "core/render/bsdf.h"

#include <cmath>
#include <map>
#include <vector>

#include <gtest/gtest.h>

namespace relit::render {
namespace {

Vec3f DirectionFromCos(float mu) { return Vec3f(std::sqrt(1.0f - mu * mu), 0.0f, mu); }

// Directional albedo of GGX with F = 1, from tools/reference/ggx_albedo.py
// (deterministic quadrature in the half-vector domain, independent code;
// cross-checked there against plain cosine-weighted Monte Carlo).
const std::map<float, std::vector<double>> kReferenceAlbedo = {
    // alpha -> E(mu) for mu = 0.2, 0.5, 0.8, 1.0
    {0.02f, {0.99367, 0.99895, 0.99957, 0.99933}},
    {0.05f, {0.96262, 0.99296, 0.99649, 0.99724}},
    {0.13f, {0.88389, 0.94903, 0.97296, 0.97942}},
    {0.34f, {0.83022, 0.79499, 0.82198, 0.84279}},
    {0.70f, {0.73072, 0.58990, 0.52637, 0.50372}},
    {1.00f, {0.64165, 0.45069, 0.35126, 0.30685}},
};
const float kMus[] = {0.2f, 0.5f, 0.8f, 1.0f};

TEST(Ggx, DistributionIsNormalised) {
  // Integral of D(h) cos(theta_h) over the hemisphere is 1.
  for (float alpha : {0.05f, 0.13f, 0.34f, 1.0f}) {
    const int n_theta = 4000, n_phi = 1;
    double sum = 0;
    for (int i = 0; i < n_theta; ++i) {
      const double theta = (i + 0.5) * (M_PI / 2) / n_theta;
      const Vec3f h(std::sin(theta), 0, std::cos(theta));
      sum += GgxD(h, alpha) * std::cos(theta) * std::sin(theta) * (M_PI / 2) / n_theta * 2 * M_PI / n_phi;
    }
    EXPECT_NEAR(sum, 1.0, 2e-3) << "alpha " << alpha;
  }
}

TEST(Ggx, DirectionalAlbedoMatchesReferenceWithinOnePercent) {
  // Importance-sampled estimate with the renderer's own sampling and weights.
  BsdfParams p;
  p.diffuse = Rgb::Zero();
  p.specular = Rgb::Ones();
  p.f0 = Rgb::Ones();  // Fresnel = 1 isolates D and G
  Rng rng(7, 1);
  const int n = 200000;
  for (const auto& [alpha, reference] : kReferenceAlbedo) {
    p.alpha = alpha;
    for (int m = 0; m < 4; ++m) {
      const Vec3f wo = DirectionFromCos(kMus[m]);
      double sum = 0, sum2 = 0;
      for (int i = 0; i < n; ++i) {
        BsdfSample s;
        const float u = rng.Uniform();
        const double w = SampleBsdf(p, wo, u, rng.Uniform2(), &s) ? s.weight[0] : 0.0;
        sum += w;
        sum2 += w * w;
      }
      const double mean = sum / n;
      const double stderr_ = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
      EXPECT_LT(std::abs(mean - reference[m]), 0.01 * reference[m])
          << "alpha " << alpha << " mu " << kMus[m] << " estimate " << mean << " +- " << stderr_;
      // The estimate must also be statistically consistent, not just close.
      EXPECT_LT(std::abs(mean - reference[m]), 5 * stderr_ + 2e-4)
          << "alpha " << alpha << " mu " << kMus[m];
    }
  }
}

TEST(Ggx, ReciprocityAndPositivity) {
  BsdfParams p;
  p.diffuse = Rgb(0.3f, 0.2f, 0.1f);
  p.specular = Rgb::Ones();
  p.alpha = 0.2f;
  Rng rng(3, 3);
  for (int i = 0; i < 1000; ++i) {
    const Vec3f a = SampleCosineHemisphere(rng.Uniform2()), b = SampleCosineHemisphere(rng.Uniform2());
    const Rgb fab = EvalBsdf(p, a, b), fba = EvalBsdf(p, b, a);
    EXPECT_TRUE((fab >= 0).all());
    // Schlick Fresnel uses wo.h = wi.h, so the sum is exactly reciprocal.
    EXPECT_LT((fab - fba).abs().maxCoeff(), 1e-4f * (1 + fab.maxCoeff()));
  }
  EXPECT_EQ(EvalBsdf(p, Vec3f(0, 0, 1), Vec3f(0, 0, -1)).maxCoeff(), 0.0f);
}

// Chi-square goodness of fit of SampleBsdf against PdfBsdf on a (cos theta, phi) grid.
double ChiSquareCritical(int dof) {
  // Wilson-Hilferty approximation of the chi-square quantile at p = 1e-4.
  const double z = 3.719, k = dof;
  const double t = 1 - 2 / (9 * k) + z * std::sqrt(2 / (9 * k));
  return k * t * t * t;
}

void RunChiSquare(const BsdfParams& p, const Vec3f& wo) {
  const int n_cos = 16, n_phi = 32, sub = 12, n = 300000;
  std::vector<double> observed(n_cos * n_phi, 0), expected(n_cos * n_phi, 0);
  Rng rng(11, 5);
  for (int i = 0; i < n; ++i) {
    BsdfSample s;
    const float u = rng.Uniform();
    if (!SampleBsdf(p, wo, u, rng.Uniform2(), &s)) continue;
    // The pdf reported with the sample equals PdfBsdf of its direction.
    ASSERT_NEAR(s.pdf, PdfBsdf(p, wo, s.wi), 1e-3f * s.pdf);
    float phi = std::atan2(s.wi.y(), s.wi.x());
    if (phi < 0) phi += 2 * kPi;
    const int ic = std::min(static_cast<int>(s.wi.z() * n_cos), n_cos - 1);
    const int ip = std::min(static_cast<int>(phi / (2 * kPi) * n_phi), n_phi - 1);
    observed[ic * n_phi + ip] += 1;
  }
  for (int ic = 0; ic < n_cos; ++ic) {
    for (int ip = 0; ip < n_phi; ++ip) {
      double integral = 0;
      for (int a = 0; a < sub; ++a) {
        for (int b = 0; b < sub; ++b) {
          const double c = (ic + (a + 0.5) / sub) / n_cos;
          const double phi = 2 * M_PI * (ip + (b + 0.5) / sub) / n_phi;
          const double s = std::sqrt(std::max(0.0, 1 - c * c));
          const Vec3f wi(s * std::cos(phi), s * std::sin(phi), c);
          integral += PdfBsdf(p, wo, wi);
        }
      }
      // d(omega) = d(cos theta) d(phi)
      expected[ic * n_phi + ip] = integral / (sub * sub) * (1.0 / n_cos) * (2 * M_PI / n_phi) * n;
    }
  }
  // Pool low-expectation bins, as is standard.
  double chi2 = 0, pooled_obs = 0, pooled_exp = 0;
  int bins = 0;
  for (size_t i = 0; i < observed.size(); ++i) {
    if (expected[i] < 5) {
      pooled_obs += observed[i];
      pooled_exp += expected[i];
      continue;
    }
    chi2 += (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
    ++bins;
  }
  if (pooled_exp >= 5) {
    chi2 += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
    ++bins;
  }
  ASSERT_GT(bins, 10);
  EXPECT_LT(chi2, ChiSquareCritical(bins - 1)) << "alpha " << p.alpha << " wo.z " << wo.z();
}

TEST(Ggx, SamplingMatchesPdfChiSquare) {
  BsdfParams p;
  p.specular = Rgb::Ones();
  for (float alpha : {0.13f, 0.34f, 0.7f}) {
    for (float mu : {0.3f, 0.9f}) {
      p.alpha = alpha;
      p.diffuse = Rgb::Zero();
      RunChiSquare(p, DirectionFromCos(mu));
      p.diffuse = Rgb(0.5f, 0.4f, 0.3f);  // mixture of both lobes
      RunChiSquare(p, DirectionFromCos(mu));
    }
  }
}

TEST(Lambert, AlbedoAndSampling) {
  BsdfParams p;
  p.diffuse = Rgb(0.8f, 0.5f, 0.2f);
  Rng rng(1, 1);
  for (int i = 0; i < 100; ++i) {
    BsdfSample s;
    const float u = rng.Uniform();
    ASSERT_TRUE(SampleBsdf(p, Vec3f(0.6f, 0, 0.8f), u, rng.Uniform2(), &s));
    // Cosine sampling of a Lambert lobe has a constant weight equal to the albedo.
    EXPECT_LT((s.weight - p.diffuse).abs().maxCoeff(), 1e-5f);
  }
}

}  // namespace
}  // namespace relit::render
