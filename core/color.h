// Exact transfer functions (IEC 61966-2-1 sRGB and pure gamma 2.2).
#pragma once

#include "core/image.h"

namespace relit {

float SrgbToLinear(float encoded);
float LinearToSrgb(float linear);
float Gamma22ToLinear(float encoded);
float LinearToGamma22(float linear);

enum class TransferFunction { kLinear, kSrgb, kGamma22 };
// Parses "linear", "srgb", "gamma2.2"; throws relit::Error otherwise.
TransferFunction ParseTransferFunction(const std::string& name);
std::string ToString(TransferFunction tf);

// Applies to the first min(3, channels) channels; alpha stays linear.
Image EncodeImage(const Image& linear, TransferFunction tf);
Image DecodeImage(const Image& encoded, TransferFunction tf);

// Rec. 709 luminance of linear RGB.
inline float Luminance(float r, float g, float b) { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }

}  // namespace relit
