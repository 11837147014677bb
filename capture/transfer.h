// Linearisation of decoded video frames: the inverse of the camera's
// transfer function (sRGB or gamma 2.2 for SDR video, as in the thesis;
// HLG or PQ for HDR video, whose BT.2020 colours are converted to the
// BT.709/sRGB primaries every other stage uses).
//
// Linear values are relative: 1.0 is SDR peak white for sRGB/gamma 2.2, the
// HLG reference white (75 % signal) for HLG and 203 cd/m^2 (ITU-R BT.2408)
// for PQ, so HDR highlights above diffuse white stay above 1 in the EXRs.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "capture/video_io.h"

namespace relit::capture {

enum class Transfer { kSrgb, kGamma22, kHlg, kPq };

std::string ToString(Transfer transfer);
bool IsHdrTag(const std::string& color_transfer);

// The transfer to undo for a video. `option` is CaptureOptions::transfer:
// "auto" takes sRGB for SDR video and refuses HDR video with advice; an
// explicit choice is used as given (with a warning when it contradicts the
// stream's tag).
Transfer ResolveTransfer(const VideoInfo& info, const std::string& option);

// Exact inverse transfer functions on [0, 1] code values.
double HlgToSceneLinear(double code);   // BT.2100 inverse OETF, [0, 1]
double PqToNits(double code);           // SMPTE ST 2084 EOTF, cd/m^2

class Linearizer {
 public:
  // `bt2020_primaries`: convert BT.2020 linear RGB to BT.709.
  Linearizer(Transfer transfer, bool bt2020_primaries);
  // CV_16UC3 full-range RGB -> CV_32FC3 linear RGB (BT.709 primaries).
  cv::Mat ToLinear(const cv::Mat& rgb16) const;

 private:
  std::vector<float> lut_;  // 16-bit code -> linear
  bool convert_primaries_;
};

// Linear RGB (CV_32FC3) -> 8-bit sRGB-encoded RGB (CV_8UC3), clipped to [0, 1].
cv::Mat LinearToSrgb8(const cv::Mat& linear);

}  // namespace relit::capture
