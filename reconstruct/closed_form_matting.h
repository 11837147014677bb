// Closed-form matting (Levin, Lischinski, Weiss, "A Closed-Form Solution to
// Natural Image Matting", PAMI 2008). Within every (2r+1)^2 window alpha is
// an affine function of colour; eliminating the affine coefficients gives the
// matting Laplacian L. With the trimap's known pixels fixed, the unknown
// alphas solve L_UU a_U = -L_UK a_K (plus a weak prior towards the proxy
// silhouette). L is assembled only over windows that touch an unknown pixel
// and the reduced system is solved with Eigen's SimplicialLDLT.
#pragma once

#include <opencv2/core.hpp>

#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct {

struct MatteStats {
  int unknown_px = 0;       // unknowns of the finest solve
  int windows = 0;          // windows assembled at the finest level
  int levels = 1;           // 1 = single scale
  double seconds = 0;
};

// `image`: CV_32FC3 colour in [0, 1] (sRGB-encoded values, as Levin et al.);
// `trimap`: CV_8U 0 / 128 / 255; `prior`: CV_32F in [0, 1] (the binary
// silhouette) or empty for no prior. Returns CV_32F alpha in [0, 1].
// Throws relit::Error when sizes mismatch or the trimap has no unknown pixel.
cv::Mat SolveClosedFormMatte(const cv::Mat& image, const cv::Mat& trimap, const cv::Mat& prior,
                             const MattingOptions& options, MatteStats* stats);

}  // namespace relit::reconstruct
