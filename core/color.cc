#include "core/color.h"

#include <cmath>

#include "core/error.h"

namespace relit {

float SrgbToLinear(float v) {
  if (v <= 0.04045f) return v / 12.92f;
  return std::pow((v + 0.055f) / 1.055f, 2.4f);
}

float LinearToSrgb(float v) {
  if (v <= 0.0031308f) return 12.92f * v;
  return 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

float Gamma22ToLinear(float v) { return v <= 0 ? 0.0f : std::pow(v, 2.2f); }
float LinearToGamma22(float v) { return v <= 0 ? 0.0f : std::pow(v, 1.0f / 2.2f); }

TransferFunction ParseTransferFunction(const std::string& name) {
  if (name == "linear") return TransferFunction::kLinear;
  if (name == "srgb") return TransferFunction::kSrgb;
  if (name == "gamma2.2") return TransferFunction::kGamma22;
  Fail("unknown transfer function '", name, "' (expected linear, srgb or gamma2.2)");
}

std::string ToString(TransferFunction tf) {
  switch (tf) {
    case TransferFunction::kLinear: return "linear";
    case TransferFunction::kSrgb: return "srgb";
    case TransferFunction::kGamma22: return "gamma2.2";
  }
  return "?";
}

namespace {
template <typename F>
Image MapColourChannels(const Image& in, F f) {
  Image out = in;
  const int colour = std::min(3, in.channels());
  const int n = in.channels();
  std::vector<float>& d = out.data();
  for (size_t i = 0; i < in.pixel_count(); ++i) {
    for (int c = 0; c < colour; ++c) d[i * n + c] = f(d[i * n + c]);
  }
  return out;
}
}  // namespace

Image EncodeImage(const Image& linear, TransferFunction tf) {
  switch (tf) {
    case TransferFunction::kLinear: return linear;
    case TransferFunction::kSrgb: return MapColourChannels(linear, [](float v) { return LinearToSrgb(std::max(v, 0.0f)); });
    case TransferFunction::kGamma22: return MapColourChannels(linear, LinearToGamma22);
  }
  return linear;
}

Image DecodeImage(const Image& encoded, TransferFunction tf) {
  switch (tf) {
    case TransferFunction::kLinear: return encoded;
    case TransferFunction::kSrgb: return MapColourChannels(encoded, SrgbToLinear);
    case TransferFunction::kGamma22: return MapColourChannels(encoded, Gamma22ToLinear);
  }
  return encoded;
}

}  // namespace relit
