#include "relight/cues_baseline.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "core/error.h"
#include "relight/cue_frames.h"

namespace relit::relight {

namespace {

// Index of (i, j), i <= j, in a packed upper triangle of a 5 x 5 matrix.
int Packed(int i, int j) { return i * 5 - i * (i - 1) / 2 + (j - i); }

Eigen::Matrix<double, 5, 5> Unpack(const std::array<double, 15>& a) {
  Eigen::Matrix<double, 5, 5> m;
  for (int i = 0; i < 5; ++i) {
    for (int j = i; j < 5; ++j) m(i, j) = m(j, i) = a[Packed(i, j)];
  }
  return m;
}

void CheckCueFrame(const Image& cue_frame) {
  RELIT_REQUIRE(cue_frame.channels() == static_cast<int>(CueFrameChannels().size()),
                "cue frame has ", cue_frame.channels(), " channels, expected ", CueFrameChannels().size());
}

}  // namespace

CuesOnlyBaseline::CuesOnlyBaseline(int resolution_px, double ridge, double saturation_level)
    : resolution_(resolution_px), ridge_(ridge), saturation_level_(saturation_level), normals_(static_cast<size_t>(resolution_px) * resolution_px * 3) {
  RELIT_REQUIRE(resolution_px >= 1 && ridge > 0, "cues-only baseline: resolution >= 1 and ridge > 0 required");
}

int CuesOnlyBaseline::Texel(float u, float v) const {
  const int x = std::clamp(static_cast<int>(u * resolution_), 0, resolution_ - 1);
  const int y = std::clamp(static_cast<int>((1.0f - v) * resolution_), 0, resolution_ - 1);
  return y * resolution_ + x;
}

void CuesOnlyBaseline::Add(Normal& n, const double* cue, double target) {
  for (int i = 0; i < kBases; ++i) {
    for (int j = i; j < kBases; ++j) n.a[Packed(i, j)] += cue[i] * cue[j];
    n.b[i] += cue[i] * target;
  }
  n.count += 1;
}

void CuesOnlyBaseline::Accumulate(const Image& cue_frame, const Image& target_rgb, const Image& matte) {
  CheckCueFrame(cue_frame);
  RELIT_REQUIRE(cue_frame.width() == target_rgb.width() && cue_frame.height() == target_rgb.height() &&
                    matte.width() == cue_frame.width() && matte.height() == cue_frame.height(),
                "cues-only baseline: cue frame, target and matte differ in size");
  for (int y = 0; y < cue_frame.height(); ++y) {
    for (int x = 0; x < cue_frame.width(); ++x) {
      const float* p = cue_frame.pixel(x, y);
      if (matte.at(x, y, 0) < 0.5f || p[21] < 0.5f) continue;
      const float target[3] = {target_rgb.at(x, y, 0), target_rgb.at(x, y, 1), target_rgb.at(x, y, 2)};
      AccumulatePixel(p, p[15], p[16], target);
    }
  }
}

void CuesOnlyBaseline::AccumulatePixel(const float* cues, float u, float v, const float* target_rgb) {
  solved_ = false;
  if (saturation_level_ > 0 && std::max({target_rgb[0], target_rgb[1], target_rgb[2]}) >= saturation_level_) return;
  const int texel = Texel(u, v);
  for (int c = 0; c < 3; ++c) {
    double cue[kBases];
    for (int k = 0; k < kBases; ++k) cue[k] = cues[3 * k + c];
    Add(normals_[texel * 3 + c], cue, target_rgb[c]);
    Add(global_[c], cue, target_rgb[c]);
  }
  ++pixels_used_;
}

int64_t CuesOnlyBaseline::texels_seen() const {
  int64_t seen = 0;
  for (size_t texel = 0; texel * 3 < normals_.size(); ++texel) seen += normals_[texel * 3].count > 0 ? 1 : 0;
  return seen;
}

void CuesOnlyBaseline::Solve() {
  RELIT_REQUIRE(pixels_used_ > 0, "cues-only baseline: no foreground pixel in the training frames");
  std::array<Eigen::Matrix<double, 5, 1>, 3> global_w;
  for (int c = 0; c < 3; ++c) {
    Eigen::Matrix<double, 5, 5> a = Unpack(global_[c].a);
    a.diagonal().array() += 1e-9 * (a.trace() / 5 + 1e-30);
    global_w[c] = a.ldlt().solve(Eigen::Map<const Eigen::Matrix<double, 5, 1>>(global_[c].b.data()));
  }
  weights_.assign(static_cast<size_t>(resolution_) * resolution_, {});
  for (size_t texel = 0; texel < weights_.size(); ++texel) {
    for (int c = 0; c < 3; ++c) {
      const Normal& n = normals_[texel * 3 + c];
      Eigen::Matrix<double, 5, 1> w = global_w[c];
      if (n.count > 0) {
        // Ridge towards the global fit, scaled like `ridge_` average pixels.
        Eigen::Matrix<double, 5, 5> a = Unpack(n.a);
        const Eigen::Matrix<double, 5, 5> g = Unpack(global_[c].a) / global_[c].count;
        Eigen::Matrix<double, 5, 1> b = Eigen::Map<const Eigen::Matrix<double, 5, 1>>(n.b.data());
        const Eigen::Matrix<double, 5, 5> prior = ridge_ * Eigen::Matrix<double, 5, 5>(g.diagonal().asDiagonal());
        a += prior;
        b += prior * global_w[c];
        w = a.ldlt().solve(b);
      }
      for (int k = 0; k < kBases; ++k) weights_[texel][k * 3 + c] = static_cast<float>(w[k]);
    }
  }
  solved_ = true;
}

Image CuesOnlyBaseline::Predict(const Image& cue_frame) const {
  RELIT_REQUIRE(solved_, "cues-only baseline: Solve() before Predict()");
  return PredictFromCueWeights(cue_frame, [&](float u, float v) { return weights_[Texel(u, v)]; });
}

}  // namespace relit::relight
