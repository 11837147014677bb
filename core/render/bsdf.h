// Reflectance models: Lambert and Cook-Torrance microfacet (GGX distribution,
// Smith height-correlated masking-shadowing, Schlick Fresnel), and their sum.
//
// All directions are in the local shading frame (z = normal), unit length,
// pointing away from the surface. `alpha` is the GGX alpha (DNL/relit
// "roughness" r maps to alpha = r; see docs/conventions.md).
#pragma once

#include "core/render/sampling.h"

namespace relit::render {

float GgxD(const Vec3f& half_local, float alpha);
float GgxLambda(const Vec3f& w_local, float alpha);
float SmithG1(const Vec3f& w_local, float alpha);
// Height-correlated masking-shadowing G2 = 1 / (1 + Lambda(wo) + Lambda(wi)).
float SmithG2(const Vec3f& wo_local, const Vec3f& wi_local, float alpha);
Rgb FresnelSchlick(const Rgb& f0, float cos_theta);
// Samples a microfacet normal from the distribution of visible normals
// (Heitz 2018) for direction wo (wo.z > 0).
Vec3f SampleGgxVisibleNormal(const Vec3f& wo_local, float alpha, const Vec2f& u);

// Parameters of the combined BSDF at one surface point.
struct BsdfParams {
  Rgb diffuse = Rgb::Zero();   // Lambert albedo
  Rgb specular = Rgb::Zero();  // multiplier of the microfacet lobe
  float alpha = 0.1f;          // GGX alpha, clamped to >= 1e-3 internally
  Rgb f0 = Rgb::Constant(0.04f);  // Fresnel reflectance at normal incidence
};

// f(wo, wi) without the cosine factor. Zero for wi or wo below the surface.
Rgb EvalBsdf(const BsdfParams& p, const Vec3f& wo, const Vec3f& wi);
// Solid-angle pdf of SampleBsdf producing wi.
float PdfBsdf(const BsdfParams& p, const Vec3f& wo, const Vec3f& wi);

struct BsdfSample {
  Vec3f wi;
  float pdf = 0;
  Rgb weight = Rgb::Zero();  // f * cos(theta_i) / pdf
};
// Picks the diffuse or the specular lobe by their albedo, then samples it.
// Returns false when no valid direction was produced.
bool SampleBsdf(const BsdfParams& p, const Vec3f& wo, float u_lobe, const Vec2f& u,
                BsdfSample* sample);

// Probability of choosing the specular lobe in SampleBsdf.
float SpecularLobeProbability(const BsdfParams& p);

}  // namespace relit::render
