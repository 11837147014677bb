#include "relight/cue_texture_fit.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "core/options.h"
#include "relight/cue_frames.h"

namespace relit::relight {

namespace {

constexpr int kBases = CueTextureFit::kBases;
using Vec5 = Eigen::Matrix<double, kBases, 1>;
using Mat5 = Eigen::Matrix<double, kBases, kBases>;

// The 4 texels and bilinear weights at (u, v) on a res x res grid, texel
// centres at (x + 0.5) / res, row 0 at v = 1, clamped at the border.
struct Bilinear {
  int texel[4];
  double weight[4];
};

Bilinear BilinearAt(float u, float v, int res) {
  const double px = static_cast<double>(u) * res - 0.5, py = (1.0 - static_cast<double>(v)) * res - 0.5;
  const double fx0 = std::floor(px), fy0 = std::floor(py);
  const double fx = px - fx0, fy = py - fy0;
  const int x0 = static_cast<int>(fx0), y0 = static_cast<int>(fy0);
  auto clamp = [res](int i) { return std::clamp(i, 0, res - 1); };
  const int xa = clamp(x0), xb = clamp(x0 + 1), ya = clamp(y0), yb = clamp(y0 + 1);
  return {{ya * res + xa, ya * res + xb, yb * res + xa, yb * res + xb},
          {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy}};
}

// Resamples a res_in^2 grid of 5-vectors (one channel) to res_out^2, reading
// the coarse grid bilinearly at the fine texel centres.
std::vector<double> Prolong(const std::vector<double>& coarse, int res_in, int res_out) {
  std::vector<double> fine(static_cast<size_t>(res_out) * res_out * kBases);
  for (int y = 0; y < res_out; ++y) {
    for (int x = 0; x < res_out; ++x) {
      const Bilinear b = BilinearAt(static_cast<float>((x + 0.5) / res_out),
                                    static_cast<float>(1.0 - (y + 0.5) / res_out), res_in);
      double* out = &fine[(static_cast<size_t>(y) * res_out + x) * kBases];
      for (int j = 0; j < 4; ++j) {
        for (int k = 0; k < kBases; ++k) out[k] += b.weight[j] * coarse[static_cast<size_t>(b.texel[j]) * kBases + k];
      }
    }
  }
  return fine;
}

double Dot(const std::vector<double>& a, const std::vector<double>& b) {
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i) sum += a[i] * b[i];
  return sum;
}

// Channel c of the fit's prediction: sum_k w[k * 3 + c] cue[k * 3 + c].
double PredictChannel(const std::array<float, CueTextureFit::kWeights>& w, const float* cues, int c) {
  double predicted = 0;
  for (int k = 0; k < CueTextureFit::kBases; ++k) predicted += w[3 * k + c] * cues[3 * k + c];
  return predicted;
}

}  // namespace

double ResolveSaturationLevel(double level, const std::string& capture_transfer) {
  if (level >= 0) return level;
  return capture_transfer == "srgb" || capture_transfer == "gamma2.2" ? CueFitOptions::kSdrSaturationLevel : 0.0;
}

RELIT_OPTION_FIELDS(CueFitOptions,
    .Add("smoothness_diffuse", &S::smoothness_diffuse, 0.0, 1e6, "neighbour coupling of the Lambert weight")
    .Add("smoothness_specular", &S::smoothness_specular, 0.0, 1e6, "neighbour coupling of the 4 GGX weights")
    .Add("ridge", &S::ridge, 1e-9, 1e6, "pull towards the global fit (pixels' worth)")
    .Add("iterations_per_level", &S::iterations_per_level, 1, 100000, "conjugate-gradient iterations per level")
    .Add("tolerance", &S::tolerance, 0.0, 1.0, "relative residual that ends a level early")
    .Add("coarse_levels", &S::coarse_levels, 0, 8, "coarser levels solved first (each half the size)")
    .Add("max_pixels", &S::max_pixels, int64_t{1000}, int64_t{1} << 40,
         "training pixels kept (evenly strided beyond)")
    .Add("saturation_level", &S::saturation_level, kAutoSaturationLevel, 1e9,
         "a training pixel's channel at or above this linear level was clipped by the video: the fit (and the "
         "training loss) only asks the prediction to be at least its value; -1 (auto) = 0.9 for SDR video "
         "(capture.json transfer srgb / gamma2.2), else 0; 0 = every pixel an equality")
    .Add("saturation_rounds", &S::saturation_rounds, 0, 100,
         "active-set rounds for the clipped channels (each a solve at the final level)")
    .Add("clip_overshoot", &S::clip_overshoot, kAutoClipOvershoot, 100.0,
         "clip_model lift: a clipped channel's lower bound as a multiple of its reading; -1 (auto) = the median "
         "overshoot the one-sided fit predicts for the clipped channels (at least 1), then solved again; 1 = the "
         "reading")
    .Add("clip_model", &S::clip_model, {"censored", "lift"},
         "how clipped channels enter the fit after the one-sided rounds: censored = EM rounds of a censored "
         "(Tobit) model, each clipped reading replaced by the radiance expected above it under the fit and the "
         "bright unclipped pixels' relative noise; lift = every clipped reading x clip_overshoot is a lower bound")
    .Add("censored_rounds", &S::censored_rounds, 0, 100, "EM rounds of clip_model censored (each a solve)")
    .Add("align_rounds", &S::align_rounds, 0, 20,
         "> 0: after each solve, shift every frame's image and matte by the sub-pixel translation that best "
         "matches the fit, then solve again")
    .Add("max_shift_px", &S::max_shift_px, 0.0, 100.0, "largest alignment shift")
    .Add("robust_rounds", &S::robust_rounds, 0, 20,
         "rounds of reweighted least squares after the solve (Cauchy weights on each pixel's residual): pixels "
         "no cue weights explain pull their texels less; 0 = plain least squares")
    .Add("robust_scale", &S::robust_scale, 0.05, 100.0,
         "the Cauchy weight's scale, in robust sigmas (1.4826 x the median residual): a pixel this far off "
         "weighs 1/2"))

void CueFitOptions::Check() const {
  RELIT_REQUIRE(saturation_level >= 0 || saturation_level == kAutoSaturationLevel,
                "saturation_level must be >= 0 or -1 (auto), got ", saturation_level);
  RELIT_REQUIRE(clip_overshoot >= 1 || clip_overshoot == kAutoClipOvershoot,
                "clip_overshoot must be >= 1 or -1 (auto), got ", clip_overshoot);
}

nlohmann::json CueFitStats::ToJson() const {
  return {{"pixels", pixels},          {"saturated_pixels", saturated_pixels}, {"saturated_above", saturated_above}, {"texels_seen", texels_seen},
          {"iterations", iterations},  {"rms_residual", rms_residual},         {"median_shift_px", median_shift_px},
          {"max_shift_px", max_shift_px}, {"clip_overshoot", clip_overshoot}, {"robust_sigma", robust_sigma},
          {"robust_downweighted", robust_downweighted}, {"clip_noise", clip_noise}, {"clip_mean_lift", clip_mean_lift}};
}

CueTextureFit::CueTextureFit(int resolution_px, const CueFitOptions& options)
    : resolution_(resolution_px), options_(options) {
  CheckOptions(options_, "cue_fit");
  RELIT_REQUIRE(resolution_px >= 1, "cue fit: resolution must be >= 1, got ", resolution_px);
}

void CueTextureFit::SetWeights(std::vector<float> weights) {
  RELIT_REQUIRE(weights.size() == static_cast<size_t>(resolution_) * resolution_ * kWeights, "cue fit: ",
                weights.size(), " weights for a ", resolution_, "^2 grid of ", kWeights);
  weights_ = std::move(weights);
  solved_ = true;
}

void CueTextureFit::AddPixel(const float* cues, float u, float v, const float* target_rgb) {
  solved_ = false;
  // Streaming decimation: keep every stride-th pixel offered; when twice the
  // budget is held, drop every other one and double the stride.
  if (offered_++ % stride_ != 0) return;
  Sample s;
  s.u = u;
  s.v = v;
  std::copy(cues, cues + kWeights, s.cues.begin());
  std::copy(target_rgb, target_rgb + 3, s.target.begin());
  MarkClipped(&s);
  loose_.push_back(s);
  if (static_cast<int64_t>(loose_.size()) >= 2 * options_.max_pixels) {
    size_t kept = 0;
    for (size_t i = 0; i < loose_.size(); i += 2) loose_[kept++] = loose_[i];
    loose_.resize(kept);
    stride_ *= 2;
  }
}

void CueTextureFit::AddFrame(const Image& cue_frame, const Image& target_rgb, const Image& matte) {
  RELIT_REQUIRE(cue_frame.channels() == static_cast<int>(CueFrameChannels().size()), "cue fit: cue frame has ",
                cue_frame.channels(), " channels, expected ", CueFrameChannels().size());
  RELIT_REQUIRE(cue_frame.width() == target_rgb.width() && cue_frame.height() == target_rgb.height() &&
                    matte.width() == cue_frame.width() && matte.height() == cue_frame.height(),
                "cue fit: cue frame, target and matte differ in size");
  const size_t n = static_cast<size_t>(cue_frame.width()) * cue_frame.height();
  std::vector<float> cues(n * kWeights), uv(n * 2), coverage(n), target(n * 3), alpha(n);
  for (int y = 0; y < cue_frame.height(); ++y) {
    for (int x = 0; x < cue_frame.width(); ++x) {
      const size_t i = static_cast<size_t>(y) * cue_frame.width() + x;
      const float* p = cue_frame.pixel(x, y);
      std::copy(p, p + kWeights, &cues[i * kWeights]);
      uv[2 * i] = p[15];
      uv[2 * i + 1] = p[16];
      coverage[i] = p[21];
      for (int c = 0; c < 3; ++c) target[3 * i + c] = target_rgb.at(x, y, c);
      alpha[i] = matte.at(x, y, 0);
    }
  }
  AddFrame({cue_frame.width(), cue_frame.height(), cues.data(), uv.data(), coverage.data(), target.data(),
            alpha.data()});
}

std::array<double, 2> CueTextureFit::FrameShift(int i) const {
  for (const Frame& f : frames_) {
    if (f.index == i) return f.shift;
  }
  return {0, 0};
}

void CueTextureFit::AddFrame(const FramePixels& in) {
  solved_ = false;
  const int index = frames_added_++;
  // The crop: the proxy's coverage plus room for the largest shift.
  int x0 = in.width, y0 = in.height, x1 = -1, y1 = -1;
  for (int y = 0; y < in.height; ++y) {
    for (int x = 0; x < in.width; ++x) {
      if (in.coverage[static_cast<size_t>(y) * in.width + x] < 0.5f) continue;
      x0 = std::min(x0, x);
      y0 = std::min(y0, y);
      x1 = std::max(x1, x);
      y1 = std::max(y1, y);
    }
  }
  if (x1 < 0) return;
  const int margin = static_cast<int>(std::ceil(options_.max_shift_px)) + 2;
  Frame f;
  f.index = index;
  f.left = std::max(0, x0 - margin);
  f.top = std::max(0, y0 - margin);
  f.width = std::min(in.width, x1 + margin + 1) - f.left;
  f.height = std::min(in.height, y1 + margin + 1) - f.top;
  const size_t n = static_cast<size_t>(f.width) * f.height;
  f.cues.resize(n * kWeights);
  f.uv.resize(n * 2);
  f.coverage.resize(n);
  f.target.resize(n * 3);
  f.matte.resize(n);
  for (int y = 0; y < f.height; ++y) {
    for (int x = 0; x < f.width; ++x) {
      const size_t o = static_cast<size_t>(y) * f.width + x;
      const size_t i = static_cast<size_t>(y + f.top) * in.width + (x + f.left);
      std::copy(in.cues + i * kWeights, in.cues + (i + 1) * kWeights, &f.cues[o * kWeights]);
      f.uv[2 * o] = in.uv[2 * i];
      f.uv[2 * o + 1] = in.uv[2 * i + 1];
      f.coverage[o] = in.coverage[i];
      for (int c = 0; c < 3; ++c) f.target[3 * o + c] = in.target_rgb[3 * i + c];
      f.matte[o] = in.matte[i];
      if (f.coverage[o] >= 0.5f && f.matte[o] >= 0.5f) ++frame_pixels_;
    }
  }
  frames_.push_back(std::move(f));
  // Frame budget: beyond twice max_pixels, every other frame is dropped.
  if (frame_pixels_ >= 2 * options_.max_pixels && frames_.size() > 1) {
    size_t kept = 0;
    frame_pixels_ = 0;
    for (size_t i = 0; i < frames_.size(); i += 2) {
      for (size_t o = 0; o < frames_[i].coverage.size(); ++o) {
        frame_pixels_ += frames_[i].coverage[o] >= 0.5f && frames_[i].matte[o] >= 0.5f;
      }
      frames_[kept++] = std::move(frames_[i]);
    }
    frames_.resize(kept);
  }
}

namespace {

// Bilinear read of channel c of a row-major w x h image with `channels`
// channels at (x, y), clamped at the border.
float ReadBilinear(const std::vector<float>& image, int w, int h, int channels, int c, double x, double y) {
  x = std::clamp(x, 0.0, w - 1.0);
  y = std::clamp(y, 0.0, h - 1.0);
  const int xa = static_cast<int>(x), ya = static_cast<int>(y);
  const int xb = std::min(xa + 1, w - 1), yb = std::min(ya + 1, h - 1);
  const double fx = x - xa, fy = y - ya;
  auto at = [&](int xi, int yi) { return image[(static_cast<size_t>(yi) * w + xi) * channels + c]; };
  return static_cast<float>((1 - fy) * ((1 - fx) * at(xa, ya) + fx * at(xb, ya)) +
                            fy * ((1 - fx) * at(xa, yb) + fx * at(xb, yb)));
}

}  // namespace

void CueTextureFit::MarkClipped(Sample* s) const {
  s->clipped = 0;
  for (int c = 0; c < 3; ++c) s->clipped |= (IsClipped(s->target[c]) ? 1 : 0) << c;
  s->expected = s->target;
}

bool CueTextureFit::IsClipped(double value) const {
  // <= 0: off, or auto left unresolved (no capture known).
  return options_.saturation_level > 0 && value >= options_.saturation_level;
}

void CueTextureFit::BuildSamples() {
  samples_ = loose_;
  // Frame pixels beyond max_pixels are strided evenly.
  const int64_t stride = std::max<int64_t>(1, (frame_pixels_ + options_.max_pixels - 1) / options_.max_pixels);
  int64_t index = 0;
  for (const Frame& f : frames_) {
    for (int y = 0; y < f.height; ++y) {
      for (int x = 0; x < f.width; ++x) {
        const size_t o = static_cast<size_t>(y) * f.width + x;
        if (f.coverage[o] < 0.5f) continue;
        const double xs = x + f.shift[0], ys = y + f.shift[1];
        if (ReadBilinear(f.matte, f.width, f.height, 1, 0, xs, ys) < 0.5f) continue;
        if (index++ % stride != 0) continue;
        Sample s;
        s.u = f.uv[2 * o];
        s.v = f.uv[2 * o + 1];
        std::copy(&f.cues[o * kWeights], &f.cues[(o + 1) * kWeights], s.cues.begin());
        for (int c = 0; c < 3; ++c) s.target[c] = ReadBilinear(f.target, f.width, f.height, 3, c, xs, ys);
        MarkClipped(&s);
        samples_.push_back(s);
      }
    }
  }
}

void CueTextureFit::AlignFrames() {
  tbb::parallel_for(size_t{0}, frames_.size(), [&](size_t i) {
    Frame& f = frames_[i];
    for (int iteration = 0; iteration < 3; ++iteration) {
      Eigen::Matrix2d jtj = Eigen::Matrix2d::Zero();
      Eigen::Vector2d jtr = Eigen::Vector2d::Zero();
      for (int y = 1; y + 1 < f.height; ++y) {
        for (int x = 1; x + 1 < f.width; ++x) {
          const size_t o = static_cast<size_t>(y) * f.width + x;
          if (f.coverage[o] < 0.99f) continue;
          const double xs = x + f.shift[0], ys = y + f.shift[1];
          if (ReadBilinear(f.matte, f.width, f.height, 1, 0, xs, ys) < 0.99f) continue;
          const std::array<float, kWeights> w = WeightsAt(f.uv[2 * o], f.uv[2 * o + 1]);
          for (int c = 0; c < 3; ++c) {
            const double t = ReadBilinear(f.target, f.width, f.height, 3, c, xs, ys);
            if (IsClipped(t)) continue;
            const double predicted = PredictChannel(w, &f.cues[o * kWeights], c);
            const Eigen::Vector2d gradient(
                0.5 * (ReadBilinear(f.target, f.width, f.height, 3, c, xs + 1, ys) -
                       ReadBilinear(f.target, f.width, f.height, 3, c, xs - 1, ys)),
                0.5 * (ReadBilinear(f.target, f.width, f.height, 3, c, xs, ys + 1) -
                       ReadBilinear(f.target, f.width, f.height, 3, c, xs, ys - 1)));
            jtj += gradient * gradient.transpose();
            jtr += gradient * (t - predicted);
          }
        }
      }
      if (jtj.trace() <= 1e-9) break;  // no texture to align on
      jtj.diagonal().array() += 1e-3 * jtj.trace();
      const Eigen::Vector2d step = -jtj.ldlt().solve(jtr);
      for (int a = 0; a < 2; ++a) {
        f.shift[a] = std::clamp(f.shift[a] + step[a], -options_.max_shift_px, options_.max_shift_px);
      }
      if (step.norm() < 0.01) break;
    }
  });
}

int CueTextureFit::SolveChannel(int c, int res, const Vec5& global, std::vector<double>* z_out) const {
  const size_t texels = static_cast<size_t>(res) * res;
  std::vector<double>& z = *z_out;
  double lambda[kBases];
  for (int k = 0; k < kBases; ++k) lambda[k] = k == 0 ? options_.smoothness_diffuse : options_.smoothness_specular;
  auto scaled_cues = [&](const Sample& s, double* out) {
    for (int k = 0; k < kBases; ++k) out[k] = s.cues[3 * k + c] / cue_scale_[3 * k + c];
  };
  // out = (J^T J + smoothness + ridge) x, J the data term's Jacobian.
  // A clipped channel predicted above its observed value has no term.
  const std::vector<char>& active = active_[c];
  auto counts = [&](size_t i) { return !(samples_[i].clipped >> c & 1) || active[i]; };
  auto apply = [&](const std::vector<double>& x, std::vector<double>* out) {
    std::fill(out->begin(), out->end(), 0.0);
    for (size_t i = 0; i < samples_.size(); ++i) {
      if (!counts(i)) continue;
      const Sample& s = samples_[i];
      double cue[kBases];
      scaled_cues(s, cue);
      const Bilinear b = BilinearAt(s.u, s.v, res);
      double pred = 0;
      for (int j = 0; j < 4; ++j) {
        const double* xt = &x[static_cast<size_t>(b.texel[j]) * kBases];
        for (int k = 0; k < kBases; ++k) pred += b.weight[j] * xt[k] * cue[k];
      }
      pred *= s.weight;
      for (int j = 0; j < 4; ++j) {
        double* ot = &(*out)[static_cast<size_t>(b.texel[j]) * kBases];
        for (int k = 0; k < kBases; ++k) ot[k] += b.weight[j] * pred * cue[k];
      }
    }
    for (int y = 0; y < res; ++y) {
      for (int xi = 0; xi < res; ++xi) {
        const size_t t = static_cast<size_t>(y) * res + xi;
        for (int k = 0; k < kBases; ++k) (*out)[t * kBases + k] += options_.ridge * x[t * kBases + k];
        auto pair = [&](size_t u) {  // each neighbour pair once
          for (int k = 0; k < kBases; ++k) {
            const double d = lambda[k] * (x[t * kBases + k] - x[u * kBases + k]);
            (*out)[t * kBases + k] += d;
            (*out)[u * kBases + k] -= d;
          }
        };
        if (xi + 1 < res) pair(t + 1);
        if (y + 1 < res) pair(t + res);
      }
    }
  };

  // Right-hand side and block-Jacobi preconditioner.
  std::vector<double> rhs(texels * kBases, 0.0);
  std::vector<Mat5> block(texels, Mat5::Zero());
  for (size_t i = 0; i < samples_.size(); ++i) {
    if (!counts(i)) continue;
    const Sample& s = samples_[i];
    double cue[kBases];
    scaled_cues(s, cue);
    const Eigen::Map<const Vec5> q(cue);
    const Bilinear b = BilinearAt(s.u, s.v, res);
    for (int j = 0; j < 4; ++j) {
      const double w = s.weight * b.weight[j];
      for (int k = 0; k < kBases; ++k) rhs[static_cast<size_t>(b.texel[j]) * kBases + k] += w * Bound(s, c) * cue[k];
      block[b.texel[j]] += (w * b.weight[j]) * q * q.transpose();
    }
  }
  std::vector<Eigen::LDLT<Mat5>> inverse(texels);
  for (int y = 0; y < res; ++y) {
    for (int x = 0; x < res; ++x) {
      const size_t t = static_cast<size_t>(y) * res + x;
      const int degree = (x > 0) + (x + 1 < res) + (y > 0) + (y + 1 < res);
      for (int k = 0; k < kBases; ++k) {
        rhs[t * kBases + k] += options_.ridge * global[k];
        block[t](k, k) += options_.ridge + lambda[k] * degree;
      }
      inverse[t].compute(block[t]);
    }
  }
  auto precondition = [&](const std::vector<double>& r, std::vector<double>* s) {
    for (size_t t = 0; t < texels; ++t) {
      Eigen::Map<Vec5> out(&(*s)[t * kBases]);
      out = inverse[t].solve(Eigen::Map<const Vec5>(&r[t * kBases]));
    }
  };

  std::vector<double> r(texels * kBases), s(texels * kBases), p, ap(texels * kBases);
  apply(z, &ap);
  for (size_t i = 0; i < r.size(); ++i) r[i] = rhs[i] - ap[i];
  precondition(r, &s);
  p = s;
  double rs = Dot(r, s);
  const double rhs_norm = std::sqrt(std::max(Dot(rhs, rhs), 1e-300));
  int iterations = 0;
  while (iterations < options_.iterations_per_level && std::sqrt(Dot(r, r)) > options_.tolerance * rhs_norm) {
    apply(p, &ap);
    const double pap = Dot(p, ap);
    if (!(pap > 0)) break;
    const double alpha = rs / pap;
    for (size_t i = 0; i < z.size(); ++i) {
      z[i] += alpha * p[i];
      r[i] -= alpha * ap[i];
    }
    precondition(r, &s);
    const double rs_next = Dot(r, s);
    const double beta = rs_next / rs;
    rs = rs_next;
    for (size_t i = 0; i < p.size(); ++i) p[i] = s[i] + beta * p[i];
    ++iterations;
  }
  return iterations;
}

int CueTextureFit::SolveWeights(bool from_scratch) {
  std::vector<int> levels;
  for (int level = from_scratch ? options_.coarse_levels : 0; level >= 0; --level) {
    const int res = resolution_ >> level;
    if (res >= 4 || level == 0) levels.push_back(std::max(res, 1));
  }
  std::array<int, 3> iterations{};
  tbb::parallel_for(0, 3, [&](int c) {
    int previous = from_scratch ? 0 : resolution_;
    for (int res : levels) {
      if (previous == 0) {
        z_[c].resize(static_cast<size_t>(res) * res * kBases);
        for (size_t t = 0; t < z_[c].size() / kBases; ++t) {
          for (int k = 0; k < kBases; ++k) z_[c][t * kBases + k] = global_[c][k];
        }
      } else if (previous != res) {
        z_[c] = Prolong(z_[c], previous, res);
      }
      iterations[c] += SolveChannel(c, res, global_[c], &z_[c]);
      previous = res;
    }
  });
  const size_t texels = static_cast<size_t>(resolution_) * resolution_;
  weights_.assign(texels * kWeights, 0.0f);
  for (size_t t = 0; t < texels; ++t) {
    for (int k = 0; k < kBases; ++k) {
      for (int c = 0; c < 3; ++c) {
        weights_[t * kWeights + 3 * k + c] = static_cast<float>(z_[c][t * kBases + k] / cue_scale_[3 * k + c]);
      }
    }
  }
  solved_ = true;
  return iterations[0] + iterations[1] + iterations[2];
}

int64_t CueTextureFit::UpdateActiveSets() {
  int64_t changed = 0;
  for (size_t i = 0; i < samples_.size(); ++i) {
    const Sample& s = samples_[i];
    if (!s.clipped) continue;
    const std::array<float, kWeights> w = WeightsAt(s.u, s.v);
    for (int c = 0; c < 3; ++c) {
      if (!(s.clipped >> c & 1)) continue;
      const char below = PredictChannel(w, s.cues.data(), c) < LowerBound(s, c) ? 1 : 0;
      changed += below != active_[c][i];
      active_[c][i] = below;
    }
  }
  return changed;
}

int CueTextureFit::SolveClipped() {
  int iterations = 0;
  for (int round = 0; round < options_.saturation_rounds; ++round) {
    if (UpdateActiveSets() == 0) break;
    iterations += SolveWeights(/*from_scratch=*/false);
  }
  return iterations;
}

double CueTextureFit::MedianClipOvershoot() const {
  std::vector<double> ratios;
  for (const Sample& s : samples_) {
    if (!s.clipped) continue;
    const std::array<float, kWeights> w = WeightsAt(s.u, s.v);
    for (int c = 0; c < 3; ++c) {
      if (s.clipped >> c & 1) ratios.push_back(std::max(1.0, PredictChannel(w, s.cues.data(), c) / s.target[c]));
    }
  }
  if (ratios.empty()) return 1.0;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  return ratios[ratios.size() / 2];
}

namespace {

// phi(a) / (1 - Phi(a)) = E[Z | Z > a] of a standard normal Z (the inverse
// Mills ratio).
double InverseMillsRatio(double a) {
  if (a > 8) return a + 1.0 / a;  // erfc loses precision; the asymptote is within 0.1 % here
  return std::sqrt(2.0 / M_PI) * std::exp(-0.5 * a * a) / std::erfc(a / std::sqrt(2.0));
}

}  // namespace

double CueTextureFit::BrightRelativeNoise() const {
  std::vector<double> relative;
  const double low = 0.3 * options_.saturation_level, high = options_.saturation_level;
  for (const Sample& s : samples_) {
    const std::array<float, kWeights> w = WeightsAt(s.u, s.v);
    for (int c = 0; c < 3; ++c) {
      if (s.clipped >> c & 1) continue;
      const double pred = PredictChannel(w, s.cues.data(), c);
      if (pred >= low && pred < high) relative.push_back(std::abs(s.target[c] - pred) / pred);
    }
  }
  if (relative.empty()) return 0.0;
  std::nth_element(relative.begin(), relative.begin() + relative.size() / 2, relative.end());
  return 1.4826 * relative[relative.size() / 2];
}

int CueTextureFit::SolveCensored(CueFitStats* stats) {
  // Floor: rendered or noiseless frames still get a finite expectation.
  constexpr double kNoiseFloor = 0.005;
  const double noise = std::max(BrightRelativeNoise(), kNoiseFloor);
  stats->clip_noise = noise;
  // Censored at each reading, the bound the one-sided fit used. Censoring
  // every clipped pixel at the saturation level instead (all a reading
  // between the level and white strictly says) scored 0.15-0.23 dB lower on
  // both the demo and the `full` spot (docs/relight.md).
  censored_ = true;
  for (auto& active : active_) std::fill(active.begin(), active.end(), 1);
  int iterations = 0;
  for (int round = 0; round < options_.censored_rounds; ++round) {
    tbb::parallel_for(size_t{0}, samples_.size(), [&](size_t i) {
      Sample& s = samples_[i];
      if (!s.clipped) return;
      const std::array<float, kWeights> w = WeightsAt(s.u, s.v);
      for (int c = 0; c < 3; ++c) {
        if (!(s.clipped >> c & 1)) continue;
        const double pred = PredictChannel(w, s.cues.data(), c), sigma = noise * s.target[c];
        s.expected[c] = static_cast<float>(pred + sigma * InverseMillsRatio((s.target[c] - pred) / sigma));
      }
    });
    iterations += SolveWeights(/*from_scratch=*/false);
  }
  double lift = 0;
  int64_t clipped = 0;
  for (const Sample& s : samples_) {
    for (int c = 0; c < 3; ++c) {
      if (!(s.clipped >> c & 1)) continue;
      lift += s.expected[c] / s.target[c];
      ++clipped;
    }
  }
  stats->clip_mean_lift = clipped > 0 ? lift / static_cast<double>(clipped) : 1.0;
  return iterations;
}

void CueTextureFit::PrepareSamples() {
  BuildSamples();
  for (auto& active : active_) active.assign(samples_.size(), 1);  // clipped fitted as equal at first
}

double CueTextureFit::Residual(const Sample& s, const std::array<float, kWeights>& w) const {
  double sq = 0;
  for (int c = 0; c < 3; ++c) {
    const double pred = PredictChannel(w, s.cues.data(), c);
    // A clipped channel only bounds the prediction from below.
    const double error = (s.clipped >> c & 1) ? std::min(0.0, pred - LowerBound(s, c)) : pred - s.target[c];
    sq += error * error;
  }
  return std::sqrt(sq / 3.0);
}

int CueTextureFit::SolveRobust(CueFitStats* stats) {
  if (options_.robust_rounds == 0 || samples_.empty()) return 0;
  constexpr double kRobustSigmaFloor = 0.01;
  double target_sq = 0;
  for (const Sample& s : samples_) target_sq += s.target[0] * s.target[0] + s.target[1] * s.target[1] + s.target[2] * s.target[2];
  const double target_rms = std::max(std::sqrt(target_sq / (3.0 * static_cast<double>(samples_.size()))), 1e-12);
  // Each texel keeps its pixels' total weight: the robust weights only say
  // which of them to believe, so the smoothness does not gain on the data
  // where the residuals are large (it would flatten the weights there).
  const size_t texels = static_cast<size_t>(resolution_) * resolution_;
  std::vector<double> count(texels, 0.0);
  std::vector<size_t> texel(samples_.size());
  for (size_t i = 0; i < samples_.size(); ++i) {
    const int x = std::clamp(static_cast<int>(samples_[i].u * resolution_), 0, resolution_ - 1);
    const int y = std::clamp(static_cast<int>((1.0f - samples_[i].v) * resolution_), 0, resolution_ - 1);
    texel[i] = static_cast<size_t>(y) * resolution_ + x;
    count[texel[i]] += 1;
  }
  int iterations = 0;
  for (int round = 0; round < options_.robust_rounds; ++round) {
    std::vector<double> residual(samples_.size());
    tbb::parallel_for(size_t{0}, samples_.size(), [&](size_t i) {
      residual[i] = Residual(samples_[i], WeightsAt(samples_[i].u, samples_[i].v));
    });
    std::vector<double> sorted = residual;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    // Floor: 1 % of the targets' RMS, below any camera's noise. Without it a
    // fit of clean data (rendered targets) takes its rounding errors for the
    // scale, weighs most pixels near 0, and the smoothness then outweighs them.
    const double sigma = std::max(1.4826 * sorted[sorted.size() / 2], kRobustSigmaFloor * target_rms);
    const double scale = options_.robust_scale * sigma;
    int64_t downweighted = 0;
    std::vector<double> weight_sum(texels, 0.0);
    for (size_t i = 0; i < samples_.size(); ++i) {
      const double z = residual[i] / scale;
      samples_[i].weight = static_cast<float>(1.0 / (1.0 + z * z));
      downweighted += samples_[i].weight < 0.5f;
      weight_sum[texel[i]] += samples_[i].weight;
    }
    for (size_t i = 0; i < samples_.size(); ++i) {
      samples_[i].weight *= static_cast<float>(count[texel[i]] / weight_sum[texel[i]]);
    }
    stats->robust_sigma = sigma;
    stats->robust_downweighted = static_cast<double>(downweighted) / static_cast<double>(samples_.size());
    iterations += SolveWeights(/*from_scratch=*/false);
    iterations += SolveClipped();
  }
  return iterations;
}

CueFitStats CueTextureFit::Solve() {
  clip_overshoot_ = 1.0;  // a second Solve starts again from the readings
  censored_ = false;
  PrepareSamples();
  RELIT_REQUIRE(!samples_.empty(), "cue fit: no foreground pixel in the training frames");
  // Unit-RMS cues, so that smoothness and ridge count in pixels' worth.
  std::array<double, kWeights> sum_sq{};
  for (const Sample& s : samples_) {
    for (int j = 0; j < kWeights; ++j) sum_sq[j] += static_cast<double>(s.cues[j]) * s.cues[j];
  }
  for (int j = 0; j < kWeights; ++j) {
    cue_scale_[j] = static_cast<float>(std::max(std::sqrt(sum_sq[j] / samples_.size()), 1e-12));
  }
  // The global fit per channel: the ridge's target and every texel's start.
  for (int c = 0; c < 3; ++c) {
    Mat5 a = Mat5::Zero();
    Vec5 b = Vec5::Zero();
    for (const Sample& s : samples_) {
      Vec5 q;
      for (int k = 0; k < kBases; ++k) q[k] = s.cues[3 * k + c] / cue_scale_[3 * k + c];
      a += q * q.transpose();
      b += s.target[c] * q;
    }
    a.diagonal().array() += 1e-9 * (a.trace() / kBases + 1e-30);
    global_[c] = a.ldlt().solve(b);
  }
  CueFitStats stats;
  stats.iterations = SolveWeights(/*from_scratch=*/true);
  stats.iterations += SolveClipped();
  // The one-sided fit leaves channels clipped in every bright frame at their
  // reading; lift every clipped reading by the overshoot the rest of the fit
  // predicts for clipped pixels, and solve again.
  const bool censored = options_.clip_model == "censored";
  const bool any_clipped =
      std::any_of(samples_.begin(), samples_.end(), [](const Sample& s) { return s.clipped != 0; });
  if (censored && any_clipped) stats.iterations += SolveCensored(&stats);
  const double overshoot = censored ? 1.0
                           : options_.clip_overshoot == CueFitOptions::kAutoClipOvershoot ? MedianClipOvershoot()
                                                                                           : options_.clip_overshoot;
  if (overshoot > 1.0) {
    clip_overshoot_ = overshoot;
    UpdateActiveSets();
    stats.iterations += SolveWeights(/*from_scratch=*/false);
    stats.iterations += SolveClipped();
  }
  stats.clip_overshoot = clip_overshoot_;
  stats.iterations += SolveRobust(&stats);
  const int rounds = frames_.empty() ? 0 : options_.align_rounds;
  for (int round = 0; round < rounds; ++round) {
    AlignFrames();
    PrepareSamples();
    censored_ = false;
    stats.iterations += SolveWeights(/*from_scratch=*/false);
    stats.iterations += SolveClipped();
    if (censored && any_clipped) stats.iterations += SolveCensored(&stats);
    stats.iterations += SolveRobust(&stats);
  }
  stats.pixels = static_cast<int64_t>(samples_.size());
  const size_t texels = static_cast<size_t>(resolution_) * resolution_;
  std::vector<char> seen(texels, 0);
  double sq = 0;
  for (const Sample& s : samples_) {
    const Bilinear b = BilinearAt(s.u, s.v, resolution_);
    for (int j = 0; j < 4; ++j) seen[b.texel[j]] |= b.weight[j] > 0 ? 1 : 0;
    stats.saturated_pixels += s.clipped != 0;
    const std::array<float, kWeights> w = WeightsAt(s.u, s.v);
    for (int c = 0; c < 3; ++c) stats.saturated_above += (s.clipped >> c & 1) && PredictChannel(w, s.cues.data(), c) > s.target[c];
    const double residual = Residual(s, w);
    sq += 3.0 * residual * residual;
  }
  stats.texels_seen = std::count(seen.begin(), seen.end(), 1);
  stats.rms_residual = std::sqrt(sq / (3.0 * samples_.size()));
  if (!frames_.empty()) {
    std::vector<double> shifts;
    for (const Frame& f : frames_) shifts.push_back(std::hypot(f.shift[0], f.shift[1]));
    std::sort(shifts.begin(), shifts.end());
    stats.median_shift_px = shifts[shifts.size() / 2];
    stats.max_shift_px = shifts.back();
  }
  return stats;
}

std::array<float, CueTextureFit::kWeights> CueTextureFit::WeightsAt(float u, float v) const {
  RELIT_REQUIRE(solved_, "cue fit: Solve() before reading weights");
  const Bilinear b = BilinearAt(u, v, resolution_);
  std::array<float, kWeights> w{};
  for (int j = 0; j < 4; ++j) {
    const float* texel = &weights_[static_cast<size_t>(b.texel[j]) * kWeights];
    for (int i = 0; i < kWeights; ++i) w[i] += static_cast<float>(b.weight[j]) * texel[i];
  }
  return w;
}

Image CueTextureFit::Predict(const Image& cue_frame) const {
  RELIT_REQUIRE(solved_, "cue fit: Solve() before Predict()");
  return PredictFromCueWeights(cue_frame, [&](float u, float v) { return WeightsAt(u, v); });
}

Image PredictFromCueWeights(const Image& cue_frame,
                            const std::function<std::array<float, 15>(float u, float v)>& weights_at) {
  RELIT_REQUIRE(cue_frame.channels() == static_cast<int>(CueFrameChannels().size()), "cue frame has ",
                cue_frame.channels(), " channels, expected ", CueFrameChannels().size());
  Image out(cue_frame.width(), cue_frame.height(), 4);
  for (int y = 0; y < cue_frame.height(); ++y) {
    for (int x = 0; x < cue_frame.width(); ++x) {
      const float* p = cue_frame.pixel(x, y);
      float* o = out.pixel(x, y);
      o[3] = p[21];
      if (p[21] <= 0) continue;
      const std::array<float, 15> w = weights_at(p[15], p[16]);
      for (int c = 0; c < 3; ++c) {
        float sum = 0;
        for (int k = 0; k < CueTextureFit::kBases; ++k) sum += w[3 * k + c] * p[3 * k + c];
        o[c] = std::max(sum, 0.0f);
      }
    }
  }
  return out;
}

}  // namespace relit::relight
