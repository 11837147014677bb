#include "core/render/cue_renderer.h"

#include <algorithm>

#include "core/error.h"
#include "core/render/light_sampling.h"

namespace relit::render {

std::vector<CueBasis> DefaultCueBasis() {
  std::vector<CueBasis> basis;
  BsdfParams lambert;
  lambert.diffuse = Rgb::Ones();
  basis.push_back({"lambert", lambert});
  for (float alpha : {0.02f, 0.05f, 0.13f, 0.34f}) {
    BsdfParams ggx;
    ggx.specular = Rgb::Ones();
    ggx.f0 = Rgb::Ones();
    ggx.alpha = alpha;
    char name[32];
    std::snprintf(name, sizeof(name), "ggx_%.2f", alpha);
    basis.push_back({name, ggx});
  }
  return basis;
}

std::vector<std::string> CueChannelNames(int count) {
  std::vector<std::string> names;
  for (int k = 0; k < count; ++k) {
    for (const char* c : {"R", "G", "B"}) names.push_back("cue" + std::to_string(k) + "." + c);
  }
  return names;
}

namespace {
constexpr int kMaxBasis = 8;

float MixturePdf(const std::vector<CueBasis>& basis, const Vec3f& wo, const Vec3f& wi) {
  float sum = 0;
  for (const CueBasis& b : basis) sum += PdfBsdf(b.bsdf, wo, wi);
  return sum / basis.size();
}

}  // namespace

void TraceCues(const Scene& scene, const std::vector<CueBasis>& basis, const Vec3f& origin_in,
               const Vec3f& direction_in, const Hit* primary, const RenderOptions& options, Rng& rng,
               float* out, float* delta_direct_out) {
  const int k_count = static_cast<int>(basis.size());
  RELIT_CHECK(k_count >= 1 && k_count <= kMaxBasis);
  Rgb throughput[kMaxBasis];
  for (int k = 0; k < k_count; ++k) throughput[k] = Rgb::Ones();
  auto add_to = [&](float* target, int k, const Rgb& value) {
    if (!value.allFinite()) return;
    for (int c = 0; c < 3; ++c) target[3 * k + c] += value[c];
  };
  auto add = [&](int k, const Rgb& value) { add_to(out, k, value); };
  Vec3f origin = origin_in, direction = direction_in.normalized();
  float bsdf_pdf = -1;  // < 0: camera ray
  // Objects outside alpha_object_ids are context (the support plane): they
  // keep their own material in every cue, so the cues hold the light they
  // bounce onto the proxy and the shadows they cast, and a camera ray that
  // sees one first is background (no cue).
  auto is_context = [&](int object_id) {
    return !options.alpha_object_ids.empty() &&
           std::find(options.alpha_object_ids.begin(), options.alpha_object_ids.end(), object_id) ==
               options.alpha_object_ids.end();
  };

  for (int bounce = 0;; ++bounce) {
    Hit hit;
    if (!NextHit(scene, bounce, primary, origin, direction, &hit)) {
      if (bsdf_pdf >= 0 || options.environment_visible) {
        const Rgb le = EscapedRadiance(scene, direction, bsdf_pdf);
        for (int k = 0; k < k_count; ++k) add(k, throughput[k] * le);
      }
      return;
    }
    if (hit.quad_light >= 0) {
      const Rgb le = EmitterRadiance(scene, hit, direction, bsdf_pdf);
      for (int k = 0; k < k_count; ++k) add(k, throughput[k] * le);
      return;
    }
    if (bounce >= options.max_depth) return;
    const bool context = is_context(hit.object_id);
    if (context && bounce == 0) return;

    const ShadingPoint shading(hit, direction);
    const Vec3f &ng = shading.ng, &wo = shading.wo;
    const Frame& frame = shading.frame;
    if (wo.z() <= 0) return;

    // The BSDF each cue sees here: its basis material on the proxy; on a
    // context object, the object's own material, the same for every cue;
    // past the primary hit on a proxy with fitted cue weights, their
    // mixture of the basis materials, the same for every cue.
    const Material& material = scene.material(hit.material);
    BsdfParams own;
    if (context) own = material.At(hit.uv);
    const std::vector<Texture>& fitted = material.cue_weights;
    const bool mixture = !context && bounce > 0 && !fitted.empty();
    Rgb weight[kMaxBasis];
    if (mixture) {
      RELIT_CHECK(static_cast<int>(fitted.size()) == k_count);
      for (int k = 0; k < k_count; ++k) weight[k] = fitted[k].Eval(hit.uv).max(0.0f);
    }
    auto sampling_pdf = [&](const Vec3f& wi) {
      return context ? PdfBsdf(own, wo, wi) : MixturePdf(basis, wo, wi);
    };
    Rgb f[kMaxBasis];
    auto eval_each = [&](const Vec3f& wi) {
      if (context) {
        const Rgb f_own = EvalBsdf(own, wo, wi);
        for (int k = 0; k < k_count; ++k) f[k] = f_own;
      } else if (mixture) {
        Rgb f_mix = Rgb::Zero();
        for (int k = 0; k < k_count; ++k) f_mix += weight[k] * EvalBsdf(basis[k].bsdf, wo, wi);
        for (int k = 0; k < k_count; ++k) f[k] = f_mix;
      } else {
        for (int k = 0; k < k_count; ++k) f[k] = EvalBsdf(basis[k].bsdf, wo, wi);
      }
    };

    // One light sample, evaluated with every cue's BSDF.
    LightSample ls;
    float select_pdf = 0;
    if (SampleOneLight(scene, hit.position, rng, &ls, &select_pdf) && ng.dot(ls.wi) > 0 &&
        Unoccluded(scene, hit.position, ng, ls)) {
      const Vec3f wi = frame.ToLocal(ls.wi);
      if (wi.z() > 0) {
        float scale = wi.z() / select_pdf;
        if (!ls.delta) {
          const float light_pdf = select_pdf * ls.pdf;
          scale = wi.z() * PowerHeuristic(light_pdf, sampling_pdf(wi)) / light_pdf;
        }
        eval_each(wi);
        // A delta light's direct light at the primary hit is exact (no
        // noise but the pixel footprint's): it may be kept apart.
        float* target = delta_direct_out != nullptr && ls.delta && bounce == 0 ? delta_direct_out : out;
        for (int k = 0; k < k_count; ++k) add_to(target, k, throughput[k] * f[k] * ls.radiance * scale);
      }
    }

    // One direction: from the mixture of the basis BSDFs, or from the context's own.
    const BsdfParams& sampled =
        context ? own : basis[std::min(static_cast<int>(rng.Uniform() * k_count), k_count - 1)].bsdf;
    BsdfSample bs;
    const float u_lobe = rng.Uniform();
    if (!SampleBsdf(sampled, wo, u_lobe, rng.Uniform2(), &bs)) return;
    const Vec3f wi_world = frame.ToWorld(bs.wi);
    if (ng.dot(wi_world) <= 0) return;
    const float mixture_pdf = sampling_pdf(bs.wi);
    if (!(mixture_pdf > 0)) return;
    eval_each(bs.wi);
    float max_throughput = 0;
    for (int k = 0; k < k_count; ++k) {
      throughput[k] *= f[k] * (bs.wi.z() / mixture_pdf);
      max_throughput = std::max(max_throughput, throughput[k].maxCoeff());
    }
    bsdf_pdf = mixture_pdf;
    origin = OffsetOrigin(hit.position, ng, wi_world);
    direction = wi_world;

    if (bounce + 1 >= options.russian_roulette_depth) {
      const float q = std::min(0.95f, max_throughput);
      if (rng.Uniform() >= q) return;
      for (int k = 0; k < k_count; ++k) throughput[k] /= q;
    }
  }
}

namespace {

// RenderCues' body; with `direct_apart`, the delta lights' direct light at
// the primary hit goes into a second block of 3 x basis channels.
RenderResult RenderCueChannels(const Scene& scene, const Camera& camera, const RenderOptions& options,
                               const std::vector<CueBasis>& basis, const RenderProgress& progress,
                               bool direct_apart) {
  RELIT_REQUIRE(!basis.empty() && static_cast<int>(basis.size()) <= kMaxBasis,
                "radiance cues need 1 to ", kMaxBasis, " basis materials, got ", basis.size());
  const int k_count = static_cast<int>(basis.size());
  std::vector<std::string> names = CueChannelNames(k_count);
  if (direct_apart) {
    for (const std::string& name : CueChannelNames(k_count)) names.push_back("direct." + name);
  }
  return RenderWithIntegrator(
      scene, camera, options, names,
      [&](const Vec3f& origin, const Vec3f& direction, const Hit* primary, Rng& rng, float* out) {
        TraceCues(scene, basis, origin, direction, primary, options, rng, out,
                  direct_apart ? out + 3 * k_count : nullptr);
      },
      progress);
}

}  // namespace

RenderResult RenderCues(const Scene& scene, const Camera& camera, const RenderOptions& options,
                        const std::vector<CueBasis>& basis, const RenderProgress& progress) {
  return RenderCueChannels(scene, camera, options, basis, progress, false);
}

RenderResult RenderCuesDeltaDirectApart(const Scene& scene, const Camera& camera, const RenderOptions& options,
                                        const std::vector<CueBasis>& basis, const RenderProgress& progress) {
  return RenderCueChannels(scene, camera, options, basis, progress, true);
}

}  // namespace relit::render
