#include "reconstruct/closed_form_matting.h"

#include <algorithm>
#include <chrono>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/run_record.h"
#include "reconstruct/trimap.h"

namespace relit::reconstruct {
namespace {

// Single-scale solve. `alpha_known` holds 0/1 for known pixels.
cv::Mat SolveLevel(const cv::Mat& image, const cv::Mat& trimap, const cv::Mat& prior,
                   const MattingOptions& options, MatteStats* stats) {
  const int width = image.cols, height = image.rows, r = options.window_radius_px;
  const int n = (2 * r + 1) * (2 * r + 1);
  // Unknown pixel numbering.
  std::vector<int> index(static_cast<size_t>(width) * height, -1);
  int unknowns = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (trimap.at<uint8_t>(y, x) == kTrimapUnknown) index[static_cast<size_t>(y) * width + x] = unknowns++;
    }
  }
  RELIT_REQUIRE(unknowns > 0, "reconstruct: the trimap has no unknown band (", width, "x", height,
                "); nothing to matte");
  // Windows touching an unknown pixel: box filter of the unknown mask.
  cv::Mat unknown_mask = (trimap == kTrimapUnknown) / 255;
  cv::Mat touching;
  cv::boxFilter(unknown_mask, touching, CV_32S, cv::Size(2 * r + 1, 2 * r + 1), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(unknowns);
  int windows = 0;
  std::vector<Eigen::Vector3d> colours(n);
  std::vector<size_t> pixels(n);
  for (int cy = r; cy < height - r; ++cy) {
    for (int cx = r; cx < width - r; ++cx) {
      if (touching.at<int>(cy, cx) == 0) continue;
      ++windows;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      int m = 0;
      for (int dy = -r; dy <= r; ++dy) {
        for (int dx = -r; dx <= r; ++dx, ++m) {
          const cv::Vec3f& c = image.at<cv::Vec3f>(cy + dy, cx + dx);
          colours[m] = Eigen::Vector3d(c[0], c[1], c[2]);
          pixels[m] = static_cast<size_t>(cy + dy) * width + (cx + dx);
          mean += colours[m];
        }
      }
      mean /= n;
      Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
      for (int i = 0; i < n; ++i) covariance += (colours[i] - mean) * (colours[i] - mean).transpose();
      covariance /= n;
      const Eigen::Matrix3d inverse = (covariance + options.epsilon / n * Eigen::Matrix3d::Identity()).inverse();
      for (int i = 0; i < n; ++i) {
        const int row = index[pixels[i]];
        if (row < 0) continue;
        const Eigen::Vector3d left = inverse * (colours[i] - mean);
        for (int j = 0; j < n; ++j) {
          const double value = (i == j ? 1.0 : 0.0) - (1.0 + left.dot(colours[j] - mean)) / n;
          const int col = index[pixels[j]];
          if (col >= 0) {
            triplets.emplace_back(row, col, value);
          } else {
            const double known = trimap.at<uint8_t>(static_cast<int>(pixels[j] / width),
                                                    static_cast<int>(pixels[j] % width)) == kTrimapForeground;
            rhs[row] -= value * known;
          }
        }
      }
    }
  }
  // Prior towards the silhouette; it also makes L_UU definite for unknown
  // regions that no window connects to a known pixel (e.g. at the border).
  // Without a silhouette only that regularisation is left (towards 1/2).
  constexpr double kRegularisation = 1e-5;
  const double lambda = prior.empty() ? kRegularisation : std::max(options.prior_weight, 1e-9);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const int row = index[static_cast<size_t>(y) * width + x];
      if (row < 0) continue;
      triplets.emplace_back(row, row, lambda);
      rhs[row] += lambda * (prior.empty() ? 0.5 : prior.at<float>(y, x));
    }
  }
  Eigen::SparseMatrix<double> laplacian(unknowns, unknowns);
  laplacian.setFromTriplets(triplets.begin(), triplets.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(laplacian);
  RELIT_REQUIRE(solver.info() == Eigen::Success, "reconstruct: the matting system could not be factorised");
  const Eigen::VectorXd solution = solver.solve(rhs);
  RELIT_REQUIRE(solver.info() == Eigen::Success, "reconstruct: the matting solve failed");
  cv::Mat alpha(height, width, CV_32F);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const int row = index[static_cast<size_t>(y) * width + x];
      const uint8_t t = trimap.at<uint8_t>(y, x);
      alpha.at<float>(y, x) =
          row >= 0 ? static_cast<float>(std::clamp(solution[row], 0.0, 1.0)) : (t == kTrimapForeground ? 1.0f : 0.0f);
    }
  }
  if (stats) {
    stats->unknown_px = unknowns;
    stats->windows = windows;
  }
  return alpha;
}

cv::Mat SolveMultiScale(const cv::Mat& image, const cv::Mat& trimap, const cv::Mat& prior,
                        const MattingOptions& options, MatteStats* stats, int level) {
  const double megapixels = image.total() / 1e6;
  if (options.multiscale_min_megapixels <= 0 || megapixels < options.multiscale_min_megapixels ||
      std::min(image.cols, image.rows) < 64) {
    stats->levels = level;
    return SolveLevel(image, trimap, prior, options, stats);
  }
  // Coarse level: half size; a coarse pixel is unknown when any of its fine
  // pixels is, else it takes their (agreeing) known value.
  const cv::Size half((image.cols + 1) / 2, (image.rows + 1) / 2);
  cv::Mat small_image, small_prior, fg, bg;
  cv::resize(image, small_image, half, 0, 0, cv::INTER_AREA);
  if (!prior.empty()) cv::resize(prior, small_prior, half, 0, 0, cv::INTER_AREA);
  cv::resize(trimap == kTrimapForeground, fg, half, 0, 0, cv::INTER_AREA);
  cv::resize(trimap == kTrimapBackground, bg, half, 0, 0, cv::INTER_AREA);
  cv::Mat small_trimap(half, CV_8U, cv::Scalar(kTrimapUnknown));
  small_trimap.setTo(kTrimapForeground, fg == 255);
  small_trimap.setTo(kTrimapBackground, bg == 255);
  const cv::Mat coarse = SolveMultiScale(small_image, small_trimap, small_prior, options, stats, level + 1);
  cv::Mat upsampled;
  cv::resize(coarse, upsampled, image.size(), 0, 0, cv::INTER_LINEAR);
  // Fine level: unknowns the coarse matte is sure about become known.
  cv::Mat fine_trimap = trimap.clone();
  const cv::Mat unknown = trimap == kTrimapUnknown;
  fine_trimap.setTo(kTrimapBackground, unknown & (upsampled < 0.01f));
  fine_trimap.setTo(kTrimapForeground, unknown & (upsampled > 0.99f));
  if (cv::countNonZero(fine_trimap == kTrimapUnknown) == 0) return upsampled;
  const int levels = stats->levels;
  cv::Mat alpha = SolveLevel(image, fine_trimap, prior, options, stats);
  stats->levels = levels;
  return alpha;
}

}  // namespace

cv::Mat SolveClosedFormMatte(const cv::Mat& image, const cv::Mat& trimap, const cv::Mat& prior,
                             const MattingOptions& options, MatteStats* stats) {
  CheckOptions(options, "matting");
  RELIT_REQUIRE(image.type() == CV_32FC3, "reconstruct: matting needs a CV_32FC3 image");
  RELIT_REQUIRE(trimap.type() == CV_8U && trimap.size() == image.size(),
                "reconstruct: the trimap must be CV_8U and the size of the image");
  RELIT_REQUIRE(prior.empty() || (prior.type() == CV_32F && prior.size() == image.size()),
                "reconstruct: the matting prior must be CV_32F and the size of the image");
  RELIT_REQUIRE(cv::countNonZero(trimap == kTrimapUnknown) > 0,
                "reconstruct: the trimap has no unknown band; nothing to matte");
  const auto start = std::chrono::steady_clock::now();
  MatteStats local;
  MatteStats* s = stats ? stats : &local;
  cv::Mat alpha = SolveMultiScale(image, trimap, prior, options, s, 1);
  s->seconds = SecondsSince(start);
  return alpha;
}

}  // namespace relit::reconstruct
