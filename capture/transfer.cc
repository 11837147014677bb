#include "capture/transfer.h"

#include <algorithm>
#include <cmath>

#include <spdlog/spdlog.h>

#include "core/color.h"
#include "core/error.h"

namespace relit::capture {

namespace {

constexpr double kHlgA = 0.17883277, kHlgB = 0.28466892, kHlgC = 0.55991073;
constexpr double kPqReferenceWhiteNits = 203.0;

double HlgReferenceWhite() { return HlgToSceneLinear(0.75); }

}  // namespace

std::string ToString(Transfer transfer) {
  switch (transfer) {
    case Transfer::kSrgb: return "srgb";
    case Transfer::kGamma22: return "gamma2.2";
    case Transfer::kHlg: return "hlg";
    case Transfer::kPq: return "pq";
  }
  return "?";
}

bool IsHdrTag(const std::string& tag) { return tag == "arib-std-b67" || tag == "smpte2084"; }

Transfer ResolveTransfer(const VideoInfo& info, const std::string& option) {
  const std::string& tag = info.color_transfer;
  if (option == "auto") {
    const char* name = tag == "arib-std-b67" ? "HLG" : "PQ";
    RELIT_REQUIRE(!IsHdrTag(tag), "the ", info.role, " ", info.path, " is HDR video (", name,
                  ", ", info.color_primaries.empty() ? "unknown" : info.color_primaries,
                  " primaries): turn off HDR video in the camera settings and film again, or pass "
                  "--transfer ", tag == "arib-std-b67" ? "hlg" : "pq", " to linearise it");
    return Transfer::kSrgb;
  }
  const Transfer chosen = option == "srgb"       ? Transfer::kSrgb
                          : option == "gamma2.2" ? Transfer::kGamma22
                          : option == "hlg"      ? Transfer::kHlg
                          : option == "pq"       ? Transfer::kPq
                                                 : (Fail("unknown transfer '", option, "'"), Transfer::kSrgb);
  const bool tag_hlg = tag == "arib-std-b67", tag_pq = tag == "smpte2084";
  if ((chosen == Transfer::kHlg && !tag_hlg) || (chosen == Transfer::kPq && !tag_pq) ||
      ((chosen == Transfer::kSrgb || chosen == Transfer::kGamma22) && (tag_hlg || tag_pq))) {
    spdlog::warn("{}: --transfer {} overrides the stream's transfer tag '{}'", info.path, option,
                 tag.empty() ? "unspecified" : tag);
  }
  return chosen;
}

double HlgToSceneLinear(double code) {
  code = std::clamp(code, 0.0, 1.0);
  if (code <= 0.5) return code * code / 3.0;
  return (std::exp((code - kHlgC) / kHlgA) + kHlgB) / 12.0;
}

double PqToNits(double code) {
  constexpr double m1 = 2610.0 / 16384.0, m2 = 2523.0 / 4096.0 * 128.0;
  constexpr double c1 = 3424.0 / 4096.0, c2 = 2413.0 / 4096.0 * 32.0, c3 = 2392.0 / 4096.0 * 32.0;
  const double p = std::pow(std::clamp(code, 0.0, 1.0), 1.0 / m2);
  return 10000.0 * std::pow(std::max(p - c1, 0.0) / (c2 - c3 * p), 1.0 / m1);
}

Linearizer::Linearizer(Transfer transfer, bool bt2020_primaries)
    : lut_(65536), convert_primaries_(bt2020_primaries) {
  const double hlg_white = HlgReferenceWhite();
  for (int code = 0; code < 65536; ++code) {
    const double v = code / 65535.0;
    double linear = 0;
    switch (transfer) {
      case Transfer::kSrgb: linear = SrgbToLinear(static_cast<float>(v)); break;
      case Transfer::kGamma22: linear = Gamma22ToLinear(static_cast<float>(v)); break;
      case Transfer::kHlg: linear = HlgToSceneLinear(v) / hlg_white; break;
      case Transfer::kPq: linear = PqToNits(v) / kPqReferenceWhiteNits; break;
    }
    lut_[code] = static_cast<float>(linear);
  }
}

cv::Mat Linearizer::ToLinear(const cv::Mat& rgb16) const {
  RELIT_CHECK(rgb16.type() == CV_16UC3);
  cv::Mat linear(rgb16.size(), CV_32FC3);
  // ITU-R BT.2087: linear BT.2020 RGB -> linear BT.709 RGB.
  static const float m[3][3] = {{1.6605f, -0.5876f, -0.0728f},
                                {-0.1246f, 1.1329f, -0.0083f},
                                {-0.0182f, -0.1006f, 1.1187f}};
  for (int y = 0; y < rgb16.rows; ++y) {
    const uint16_t* in = rgb16.ptr<uint16_t>(y);
    float* out = linear.ptr<float>(y);
    for (int x = 0; x < rgb16.cols; ++x, in += 3, out += 3) {
      const float r = lut_[in[0]], g = lut_[in[1]], b = lut_[in[2]];
      if (convert_primaries_) {
        for (int c = 0; c < 3; ++c) out[c] = std::max(0.0f, m[c][0] * r + m[c][1] * g + m[c][2] * b);
      } else {
        out[0] = r;
        out[1] = g;
        out[2] = b;
      }
    }
  }
  return linear;
}

cv::Mat LinearToSrgb8(const cv::Mat& linear) {
  RELIT_CHECK(linear.type() == CV_32FC3);
  cv::Mat out(linear.size(), CV_8UC3);
  for (int y = 0; y < linear.rows; ++y) {
    const float* in = linear.ptr<float>(y);
    uint8_t* o = out.ptr<uint8_t>(y);
    for (int i = 0; i < linear.cols * 3; ++i) {
      const float encoded = LinearToSrgb(std::clamp(in[i], 0.0f, 1.0f));
      o[i] = static_cast<uint8_t>(std::lround(std::clamp(encoded, 0.0f, 1.0f) * 255.0f));
    }
  }
  return out;
}

}  // namespace relit::capture
