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

}  // namespace

void CueFitOptions::Read(OptionsReader& reader) {
  reader.ReadRange("smoothness_diffuse", &smoothness_diffuse, 0.0, 1e6);
  reader.ReadRange("smoothness_specular", &smoothness_specular, 0.0, 1e6);
  reader.ReadRange("ridge", &ridge, 1e-9, 1e6);
  reader.ReadRange("iterations_per_level", &iterations_per_level, 1, 100000);
  reader.ReadRange("tolerance", &tolerance, 0.0, 1.0);
  reader.ReadRange("coarse_levels", &coarse_levels, 0, 8);
  reader.ReadRange("max_pixels", &max_pixels, int64_t{1000}, int64_t{1} << 40);
  reader.ReadRange("saturation_level", &saturation_level, 0.0, 1e9);
  reader.Finish();
}

void CueFitOptions::Check() const {
  RELIT_REQUIRE(smoothness_diffuse >= 0 && smoothness_specular >= 0 && ridge > 0 && iterations_per_level >= 1 &&
                    tolerance >= 0 && coarse_levels >= 0 && max_pixels >= 1000 && saturation_level >= 0,
                "cue_fit: smoothness >= 0, ridge > 0, iterations_per_level >= 1, coarse_levels >= 0 and "
                "max_pixels >= 1000 and saturation_level >= 0 required");
}

nlohmann::json CueFitOptions::ToJson() const {
  return {{"smoothness_diffuse", smoothness_diffuse}, {"smoothness_specular", smoothness_specular},
          {"ridge", ridge},   {"iterations_per_level", iterations_per_level},
          {"tolerance", tolerance}, {"coarse_levels", coarse_levels}, {"max_pixels", max_pixels},
          {"saturation_level", saturation_level}};
}

CueTextureFit::CueTextureFit(int resolution_px, const CueFitOptions& options)
    : resolution_(resolution_px), options_(options) {
  options_.Check();
  RELIT_REQUIRE(resolution_px >= 1, "cue fit: resolution must be >= 1, got ", resolution_px);
}

void CueTextureFit::AddPixel(const float* cues, float u, float v, const float* target_rgb) {
  solved_ = false;
  if (options_.saturation_level > 0 &&
      std::max({target_rgb[0], target_rgb[1], target_rgb[2]}) >= options_.saturation_level) {
    ++saturated_;
    return;
  }
  // Streaming decimation: keep every stride-th pixel offered; when twice the
  // budget is held, drop every other one and double the stride.
  if (offered_++ % stride_ != 0) return;
  Sample s;
  s.u = u;
  s.v = v;
  std::copy(cues, cues + kWeights, s.cues.begin());
  std::copy(target_rgb, target_rgb + 3, s.target.begin());
  samples_.push_back(s);
  if (static_cast<int64_t>(samples_.size()) >= 2 * options_.max_pixels) {
    size_t kept = 0;
    for (size_t i = 0; i < samples_.size(); i += 2) samples_[kept++] = samples_[i];
    samples_.resize(kept);
    stride_ *= 2;
  }
}

void CueTextureFit::AddFrame(const Image& cue_frame, const Image& target_rgb, const Image& matte) {
  RELIT_REQUIRE(cue_frame.channels() == static_cast<int>(CueFrameChannels().size()), "cue fit: cue frame has ",
                cue_frame.channels(), " channels, expected ", CueFrameChannels().size());
  RELIT_REQUIRE(cue_frame.width() == target_rgb.width() && cue_frame.height() == target_rgb.height() &&
                    matte.width() == cue_frame.width() && matte.height() == cue_frame.height(),
                "cue fit: cue frame, target and matte differ in size");
  for (int y = 0; y < cue_frame.height(); ++y) {
    for (int x = 0; x < cue_frame.width(); ++x) {
      const float* p = cue_frame.pixel(x, y);
      if (matte.at(x, y, 0) < 0.5f || p[21] < 0.5f) continue;
      const float target[3] = {target_rgb.at(x, y, 0), target_rgb.at(x, y, 1), target_rgb.at(x, y, 2)};
      AddPixel(p, p[15], p[16], target);
    }
  }
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
  auto apply = [&](const std::vector<double>& x, std::vector<double>* out) {
    std::fill(out->begin(), out->end(), 0.0);
    for (const Sample& s : samples_) {
      double cue[kBases];
      scaled_cues(s, cue);
      const Bilinear b = BilinearAt(s.u, s.v, res);
      double pred = 0;
      for (int j = 0; j < 4; ++j) {
        const double* xt = &x[static_cast<size_t>(b.texel[j]) * kBases];
        for (int k = 0; k < kBases; ++k) pred += b.weight[j] * xt[k] * cue[k];
      }
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
  for (const Sample& s : samples_) {
    double cue[kBases];
    scaled_cues(s, cue);
    const Eigen::Map<const Vec5> q(cue);
    const Bilinear b = BilinearAt(s.u, s.v, res);
    for (int j = 0; j < 4; ++j) {
      for (int k = 0; k < kBases; ++k) rhs[static_cast<size_t>(b.texel[j]) * kBases + k] += b.weight[j] * s.target[c] * cue[k];
      block[b.texel[j]] += (b.weight[j] * b.weight[j]) * q * q.transpose();
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

CueFitStats CueTextureFit::Solve() {
  RELIT_REQUIRE(!samples_.empty(), "cue fit: no unsaturated foreground pixel in the training frames (",
                saturated_, " left out at the saturation level ", options_.saturation_level, ")");
  CueFitStats stats;
  stats.pixels = static_cast<int64_t>(samples_.size());
  stats.saturated_pixels = saturated_;
  // Unit-RMS cues, so that smoothness and ridge count in pixels' worth.
  std::array<double, kWeights> sum_sq{};
  for (const Sample& s : samples_) {
    for (int j = 0; j < kWeights; ++j) sum_sq[j] += static_cast<double>(s.cues[j]) * s.cues[j];
  }
  for (int j = 0; j < kWeights; ++j) {
    cue_scale_[j] = static_cast<float>(std::max(std::sqrt(sum_sq[j] / samples_.size()), 1e-12));
  }
  // The global fit per channel: the ridge's target and every texel's start.
  std::array<Vec5, 3> global;
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
    global[c] = a.ldlt().solve(b);
  }

  std::vector<int> levels;
  for (int level = options_.coarse_levels; level >= 0; --level) {
    const int res = resolution_ >> level;
    if (res >= 4 || level == 0) levels.push_back(std::max(res, 1));
  }
  std::array<std::vector<double>, 3> z;
  std::array<int, 3> iterations{};
  tbb::parallel_for(0, 3, [&](int c) {
    int previous = 0;
    for (int res : levels) {
      if (previous == 0) {
        z[c].resize(static_cast<size_t>(res) * res * kBases);
        for (size_t t = 0; t < z[c].size() / kBases; ++t) {
          for (int k = 0; k < kBases; ++k) z[c][t * kBases + k] = global[c][k];
        }
      } else {
        z[c] = Prolong(z[c], previous, res);
      }
      iterations[c] += SolveChannel(c, res, global[c], &z[c]);
      previous = res;
    }
  });
  stats.iterations = iterations[0] + iterations[1] + iterations[2];

  const size_t texels = static_cast<size_t>(resolution_) * resolution_;
  weights_.assign(texels * kWeights, 0.0f);
  for (size_t t = 0; t < texels; ++t) {
    for (int k = 0; k < kBases; ++k) {
      for (int c = 0; c < 3; ++c) {
        weights_[t * kWeights + 3 * k + c] = static_cast<float>(z[c][t * kBases + k] / cue_scale_[3 * k + c]);
      }
    }
  }
  solved_ = true;

  std::vector<char> seen(texels, 0);
  double sq = 0;
  for (const Sample& s : samples_) {
    const Bilinear b = BilinearAt(s.u, s.v, resolution_);
    for (int j = 0; j < 4; ++j) seen[b.texel[j]] |= b.weight[j] > 0 ? 1 : 0;
    const std::array<float, kWeights> w = WeightsAt(s.u, s.v);
    for (int c = 0; c < 3; ++c) {
      double pred = 0;
      for (int k = 0; k < kBases; ++k) pred += w[3 * k + c] * s.cues[3 * k + c];
      sq += (pred - s.target[c]) * (pred - s.target[c]);
    }
  }
  stats.texels_seen = std::count(seen.begin(), seen.end(), 1);
  stats.rms_residual = std::sqrt(sq / (3.0 * samples_.size()));
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
  Image out(cue_frame.width(), cue_frame.height(), 4);
  for (int y = 0; y < cue_frame.height(); ++y) {
    for (int x = 0; x < cue_frame.width(); ++x) {
      const float* p = cue_frame.pixel(x, y);
      float* o = out.pixel(x, y);
      o[3] = p[21];
      if (p[21] <= 0) continue;
      const std::array<float, kWeights> w = WeightsAt(p[15], p[16]);
      for (int c = 0; c < 3; ++c) {
        float sum = 0;
        for (int k = 0; k < kBases; ++k) sum += w[3 * k + c] * p[3 * k + c];
        o[c] = std::max(sum, 0.0f);  // cues are pixel averages: already premultiplied
      }
    }
  }
  return out;
}

}  // namespace relit::relight
