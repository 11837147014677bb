#include "core/render/bsdf.h"

#include <algorithm>
#include <cmath>

namespace relit::render {

namespace {
constexpr float kMinAlpha = 1e-3f;
float ClampAlpha(float alpha) { return std::max(alpha, kMinAlpha); }
float Lum(const Rgb& c) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; }
}  // namespace

float GgxD(const Vec3f& h, float alpha) {
  alpha = ClampAlpha(alpha);
  if (h.z() <= 0) return 0;
  const float a2 = alpha * alpha;
  const float cos2 = h.z() * h.z();
  const float denom = cos2 * (a2 - 1.0f) + 1.0f;
  return a2 / (kPi * denom * denom);
}

float GgxLambda(const Vec3f& w, float alpha) {
  alpha = ClampAlpha(alpha);
  const float cos2 = w.z() * w.z();
  if (cos2 >= 1.0f) return 0;
  const float tan2 = std::max(0.0f, 1.0f - cos2) / std::max(cos2, 1e-12f);
  return 0.5f * (-1.0f + std::sqrt(1.0f + alpha * alpha * tan2));
}

float SmithG1(const Vec3f& w, float alpha) { return 1.0f / (1.0f + GgxLambda(w, alpha)); }

float SmithG2(const Vec3f& wo, const Vec3f& wi, float alpha) {
  return 1.0f / (1.0f + GgxLambda(wo, alpha) + GgxLambda(wi, alpha));
}

Rgb FresnelSchlick(const Rgb& f0, float cos_theta) {
  const float m = std::clamp(1.0f - cos_theta, 0.0f, 1.0f);
  const float m5 = (m * m) * (m * m) * m;
  return f0 + (Rgb::Ones() - f0) * m5;
}

Vec3f SampleGgxVisibleNormal(const Vec3f& wo, float alpha, const Vec2f& u) {
  alpha = ClampAlpha(alpha);
  // Heitz 2018, "Sampling the GGX Distribution of Visible Normals".
  const Vec3f vh = Vec3f(alpha * wo.x(), alpha * wo.y(), wo.z()).normalized();
  const float lensq = vh.x() * vh.x() + vh.y() * vh.y();
  const Vec3f t1 = lensq > 0 ? Vec3f(-vh.y(), vh.x(), 0) / std::sqrt(lensq) : Vec3f(1, 0, 0);
  const Vec3f t2 = vh.cross(t1);
  const float r = std::sqrt(u.x());
  const float phi = 2.0f * kPi * u.y();
  const float p1 = r * std::cos(phi);
  float p2 = r * std::sin(phi);
  const float s = 0.5f * (1.0f + vh.z());
  p2 = (1.0f - s) * std::sqrt(std::max(0.0f, 1.0f - p1 * p1)) + s * p2;
  const Vec3f nh = p1 * t1 + p2 * t2 + std::sqrt(std::max(0.0f, 1.0f - p1 * p1 - p2 * p2)) * vh;
  return Vec3f(alpha * nh.x(), alpha * nh.y(), std::max(1e-6f, nh.z())).normalized();
}

float SpecularLobeProbability(const BsdfParams& p) {
  const float wd = Lum(p.diffuse);
  // The specular lobe's albedo depends on Fresnel; half its multiplier is a
  // fair average between normal and grazing incidence.
  const float ws = 0.5f * Lum(p.specular);
  if (ws <= 0) return 0;
  if (wd <= 0) return 1;
  return std::clamp(ws / (wd + ws), 0.1f, 0.9f);
}

Rgb EvalBsdf(const BsdfParams& p, const Vec3f& wo, const Vec3f& wi) {
  if (wo.z() <= 0 || wi.z() <= 0) return Rgb::Zero();
  Rgb f = p.diffuse * kInvPi;
  if ((p.specular > 0).any()) {
    const Vec3f h = (wo + wi).normalized();
    const float d = GgxD(h, p.alpha);
    const float g = SmithG2(wo, wi, p.alpha);
    const Rgb fresnel = FresnelSchlick(p.f0, wo.dot(h));
    f += p.specular * fresnel * (d * g / (4.0f * wo.z() * wi.z()));
  }
  return f;
}

float PdfBsdf(const BsdfParams& p, const Vec3f& wo, const Vec3f& wi) {
  if (wo.z() <= 0 || wi.z() <= 0) return 0;
  const float p_spec = SpecularLobeProbability(p);
  float pdf = (1.0f - p_spec) * wi.z() * kInvPi;
  if (p_spec > 0) {
    const Vec3f h = (wo + wi).normalized();
    pdf += p_spec * SmithG1(wo, p.alpha) * GgxD(h, p.alpha) / (4.0f * wo.z());
  }
  return pdf;
}

bool SampleBsdf(const BsdfParams& p, const Vec3f& wo, float u_lobe, const Vec2f& u,
                BsdfSample* sample) {
  if (wo.z() <= 0) return false;
  const float p_spec = SpecularLobeProbability(p);
  if (u_lobe < p_spec) {
    const Vec3f h = SampleGgxVisibleNormal(wo, p.alpha, u);
    sample->wi = 2.0f * wo.dot(h) * h - wo;
  } else {
    sample->wi = SampleCosineHemisphere(u);
  }
  if (sample->wi.z() <= 0) return false;
  sample->pdf = PdfBsdf(p, wo, sample->wi);
  if (!(sample->pdf > 0)) return false;
  sample->weight = EvalBsdf(p, wo, sample->wi) * (sample->wi.z() / sample->pdf);
  return sample->weight.allFinite();
}

}  // namespace relit::render
