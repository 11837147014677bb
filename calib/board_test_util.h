// Test helper shared by the board-detection tests: where the ChArUco corners
// of a drawn board land once the drawing is warped into an image.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "core/board.h"

namespace relit::calib {

// The true pixel (pixel-centre coordinates) of every ChArUco corner of
// `spec` drawn by DrawBoardImage(spec, pixels_per_metre, margin_px) and
// mapped into the image by the homography `drawn_to_image`: a corner at
// (x, y) metres sits at margin + x * ppm - 0.5 in the drawing's pixel centres.
inline std::vector<Eigen::Vector2d> WarpedCornersPx(const BoardSpec& spec, double pixels_per_metre, int margin_px,
                                                    const cv::Mat& drawn_to_image) {
  const auto board = MakeCharucoBoard(spec);  // held: the corners live in it
  std::vector<Eigen::Vector2d> corners;
  for (const cv::Point3f& p : board->chessboardCorners) {
    std::vector<cv::Point2d> in = {{margin_px + p.x * pixels_per_metre - 0.5, margin_px + p.y * pixels_per_metre - 0.5}};
    std::vector<cv::Point2d> out;
    cv::perspectiveTransform(in, out, drawn_to_image);
    corners.emplace_back(out[0].x, out[0].y);
  }
  return corners;
}

}  // namespace relit::calib
