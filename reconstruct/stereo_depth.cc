#include "reconstruct/stereo_depth.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace relit::reconstruct {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

cv::Mat ToCv(const Eigen::Matrix3d& m) {
  cv::Mat out(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.at<double>(r, c) = m(r, c);
  }
  return out;
}

Eigen::Matrix3d ToEigen3(const cv::Mat& m) {
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out(r, c) = m.at<double>(r, c);
  }
  return out;
}

// One rectified pair: view 1 has view 2 on its +axis side, so disparities
// (coordinate in 1 minus coordinate in 2 along the axis) are positive.
struct Rectification {
  cv::Mat r1, r2, p1, p2;
  int axis = 0;              // 0: horizontal stereo, 1: vertical
  double focal_baseline = 0; // f x B in pixels x metres
};

Rectification Rectify(const Camera& c1, const Camera& c2) {
  const Rigid3 c2_from_c1 = c2.cam_from_world() * c1.cam_from_world().Inverse();
  const cv::Mat rotation = ToCv(c2_from_c1.rotation.toRotationMatrix());
  const cv::Mat translation = (cv::Mat_<double>(3, 1) << c2_from_c1.translation.x(), c2_from_c1.translation.y(),
                               c2_from_c1.translation.z());
  const cv::Size size(c1.intrinsics().width, c1.intrinsics().height);
  Rectification r;
  cv::Mat q;
  cv::stereoRectify(cv::Mat(c1.intrinsics().CameraMatrix()), cv::Mat(), cv::Mat(c2.intrinsics().CameraMatrix()),
                    cv::Mat(), size, rotation, translation, r.r1, r.r2, r.p1, r.p2, q, cv::CALIB_ZERO_DISPARITY, -1,
                    size);
  r.axis = std::abs(r.p2.at<double>(1, 3)) > std::abs(r.p2.at<double>(0, 3)) ? 1 : 0;
  r.focal_baseline = -r.p2.at<double>(r.axis, 3);
  return r;
}

// SGBM disparities (pixels, CV_32F, NaN = none) of `left` against `right`
// for a horizontal pair. SGBM leaves the first minDisparity + numDisparities
// columns empty, so both images are padded on the left by that much first.
cv::Mat Disparity(const cv::Ptr<cv::StereoSGBM>& sgbm, const cv::Mat& left, const cv::Mat& right) {
  const int pad = sgbm->getMinDisparity() + sgbm->getNumDisparities();
  cv::Mat left_padded, right_padded, raw, disparity;
  cv::copyMakeBorder(left, left_padded, 0, 0, pad, 0, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::copyMakeBorder(right, right_padded, 0, 0, pad, 0, cv::BORDER_CONSTANT, cv::Scalar(0));
  sgbm->compute(left_padded, right_padded, raw);
  raw.colRange(pad, raw.cols).convertTo(disparity, CV_32F, 1.0 / 16.0);
  const float invalid = static_cast<float>(sgbm->getMinDisparity());
  disparity.setTo(std::numeric_limits<float>::quiet_NaN(), disparity < invalid);
  return disparity;
}

// Drops disparities whose match in the other view points back elsewhere.
// `direction` is -1 for the left map (partner x - d), +1 for the right one.
void LeftRightCheck(cv::Mat* disparity, const cv::Mat& other, int direction, double tolerance_px) {
  for (int y = 0; y < disparity->rows; ++y) {
    float* row = disparity->ptr<float>(y);
    const float* other_row = other.ptr<float>(y);
    for (int x = 0; x < disparity->cols; ++x) {
      if (std::isnan(row[x])) continue;
      const int partner = static_cast<int>(std::lround(x + direction * row[x]));
      if (partner < 0 || partner >= other.cols || std::isnan(other_row[partner]) ||
          std::abs(other_row[partner] - row[x]) > tolerance_px) {
        row[x] = std::numeric_limits<float>::quiet_NaN();
      }
    }
  }
}

// Disparity search range from the scene box seen by rectified view 1.
void DisparityRange(const Camera& c1, const Rectification& r, const SceneBox& box, int width, int* min_disparity,
                    int* num_disparities) {
  const Eigen::Matrix3d rect_from_cam = ToEigen3(r.r1);
  double z_min = 1e30, z_max = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d p((corner & 1) ? box.max.x() : box.min.x(), (corner & 2) ? box.max.y() : box.min.y(),
                            (corner & 4) ? box.max.z() : box.min.z());
    const double z = (rect_from_cam * (c1.cam_from_world() * p)).z();
    z_min = std::min(z_min, z);
    z_max = std::max(z_max, z);
  }
  z_max = std::max(z_max, 1e-3);
  z_min = std::max(z_min, 0.1 * z_max);  // the box reaches behind the camera: search up to 10x nearer
  const int lo = std::max(0, static_cast<int>(std::floor(r.focal_baseline / z_max)) - 2);
  const int hi = static_cast<int>(std::ceil(r.focal_baseline / z_min)) + 2;
  *min_disparity = lo;
  *num_disparities = std::clamp((hi - lo + 15) / 16 * 16, 16, std::max(16, width / 2 / 16 * 16));
}

}  // namespace

std::vector<std::vector<int>> SelectStereoNeighbours(const std::vector<Camera>& cameras,
                                                     const Eigen::Vector3d& centre, const ProxyOptions& options) {
  std::vector<std::vector<int>> result(cameras.size());
  for (size_t i = 0; i < cameras.size(); ++i) {
    const Eigen::Vector3d ray_i = (cameras[i].Center() - centre).normalized();
    struct Candidate {
      int index;
      double score;
      bool right;
    };
    std::vector<Candidate> candidates;
    for (size_t j = 0; j < cameras.size(); ++j) {
      if (j == i) continue;
      const Eigen::Vector3d ray_j = (cameras[j].Center() - centre).normalized();
      const double angle = std::acos(std::clamp(ray_i.dot(ray_j), -1.0, 1.0)) * kRadToDeg;
      if (angle < options.min_baseline_deg || angle > options.max_baseline_deg) continue;
      const Eigen::Vector3d in_i = cameras[i].cam_from_world() * cameras[j].Center();
      candidates.push_back({static_cast<int>(j), std::abs(angle - options.target_baseline_deg), in_i.x() > 0});
    }
    std::sort(candidates.begin(), candidates.end(),
              [](const Candidate& a, const Candidate& b) { return a.score < b.score; });
    std::vector<bool> used(candidates.size(), false);
    for (bool side : {true, false}) {  // the best on each side first
      for (size_t k = 0; k < candidates.size(); ++k) {
        if (candidates[k].right == side && static_cast<int>(result[i].size()) < options.neighbours) {
          result[i].push_back(candidates[k].index);
          used[k] = true;
          break;
        }
      }
    }
    for (size_t k = 0; k < candidates.size() && static_cast<int>(result[i].size()) < options.neighbours; ++k) {
      if (!used[k]) result[i].push_back(candidates[k].index);
    }
  }
  return result;
}

cv::Mat PairDepthMap(const DepthView& ref, const DepthView& other, const SceneBox& box,
                     const ProxyOptions& options) {
  // Order the pair so that view 1 has view 2 on its positive side.
  Rectification rect = Rectify(ref.camera, other.camera);
  const bool ref_first = rect.focal_baseline > 0;
  if (!ref_first) rect = Rectify(other.camera, ref.camera);
  const DepthView& v1 = ref_first ? ref : other;
  const DepthView& v2 = ref_first ? other : ref;
  const cv::Size size(v1.gray.cols, v1.gray.rows);
  cv::Mat map_x, map_y, rect1, rect2;
  cv::initUndistortRectifyMap(cv::Mat(v1.camera.intrinsics().CameraMatrix()), cv::Mat(), rect.r1, rect.p1, size,
                              CV_32FC1, map_x, map_y);
  cv::remap(v1.gray, rect1, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  cv::initUndistortRectifyMap(cv::Mat(v2.camera.intrinsics().CameraMatrix()), cv::Mat(), rect.r2, rect.p2, size,
                              CV_32FC1, map_x, map_y);
  cv::remap(v2.gray, rect2, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  if (rect.axis == 1) {  // vertical pair: match along the rows of the transposed images
    cv::transpose(rect1, rect1);
    cv::transpose(rect2, rect2);
  }
  int min_disparity = 0, num_disparities = 16;
  DisparityRange(v1.camera, rect, box, rect1.cols, &min_disparity, &num_disparities);
  const int block = options.block_size_px;
  const cv::Ptr<cv::StereoSGBM> sgbm =
      cv::StereoSGBM::create(min_disparity, num_disparities, block, 8 * block * block, 32 * block * block, -1, 63,
                             options.uniqueness_ratio, options.speckle_window_px, 2, cv::StereoSGBM::MODE_SGBM);
  cv::Mat disparity1 = Disparity(sgbm, rect1, rect2);
  cv::Mat flipped1, flipped2;
  cv::flip(rect2, flipped2, 1);
  cv::flip(rect1, flipped1, 1);
  cv::Mat disparity2 = Disparity(sgbm, flipped2, flipped1);
  cv::flip(disparity2, disparity2, 1);
  const cv::Mat checked1 = disparity1.clone();
  LeftRightCheck(&disparity1, disparity2, -1, options.max_left_right_difference_px);
  LeftRightCheck(&disparity2, checked1, +1, options.max_left_right_difference_px);
  if (rect.axis == 1) {
    cv::transpose(disparity1, disparity1);
    cv::transpose(disparity2, disparity2);
  }

  // Sample the reference side's disparities at its own (unrectified) pixels.
  const cv::Mat& disparity = ref_first ? disparity1 : disparity2;
  const cv::Mat& r_ref = ref_first ? rect.r1 : rect.r2;
  const cv::Mat& p_ref = ref_first ? rect.p1 : rect.p2;
  const Eigen::Matrix3d rect_rotation = ToEigen3(r_ref);
  const Eigen::Matrix3d p3 = ToEigen3(p_ref.colRange(0, 3));
  Eigen::Matrix3d k;
  const cv::Matx33d kc = ref.camera.intrinsics().CameraMatrix();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) k(r, c) = kc(r, c);
  }
  const Eigen::Matrix3d rect_from_pixel = p3 * rect_rotation * k.inverse();
  const double f = p_ref.at<double>(0, 0), cx = p_ref.at<double>(0, 2), cy = p_ref.at<double>(1, 2);
  cv::Mat depth(ref.gray.rows, ref.gray.cols, CV_32F, cv::Scalar(0));
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      const Eigen::Vector3d h = rect_from_pixel * Eigen::Vector3d(u, v, 1);
      const double rx = h.x() / h.z(), ry = h.y() / h.z();
      const int ix = static_cast<int>(std::lround(rx)), iy = static_cast<int>(std::lround(ry));
      if (ix < 0 || iy < 0 || ix >= disparity.cols || iy >= disparity.rows) continue;
      const float d = disparity.at<float>(iy, ix);
      if (std::isnan(d) || d <= 0) continue;
      const double z = rect.focal_baseline / d;
      const Eigen::Vector3d point_rect((rx - cx) * z / f, (ry - cy) * z / f, z);
      depth.at<float>(v, u) = static_cast<float>((rect_rotation.transpose() * point_rect).z());
    }
  }
  return depth;
}

namespace {

// Clears the known depths where `condition` (CV_8U, same size) is set;
// returns how many.
int ClearKnownDepthsWhere(const cv::Mat& condition, cv::Mat* depth) {
  const cv::Mat clear = condition & (*depth > 0);
  depth->setTo(0, clear);
  return cv::countNonZero(clear);
}

}  // namespace

int DropTexturelessDepths(const cv::Mat& gray, double min_texture, int block_size_px, cv::Mat* depth) {
  if (min_texture <= 0) return 0;
  RELIT_REQUIRE(gray.size() == depth->size(), "DropTexturelessDepths: image ", gray.cols, "x", gray.rows,
                " and depth map ", depth->cols, "x", depth->rows, " differ");
  cv::Mat value, mean, mean_square;
  gray.convertTo(value, CV_32F);
  const cv::Size window(block_size_px, block_size_px);
  cv::blur(value, mean, window, cv::Point(-1, -1), cv::BORDER_REFLECT);
  cv::blur(value.mul(value), mean_square, window, cv::Point(-1, -1), cv::BORDER_REFLECT);
  const cv::Mat variance = mean_square - mean.mul(mean);
  return ClearKnownDepthsWhere(variance < min_texture * min_texture, depth);
}

int DropDepthsNearFartherEdges(int margin_px, double jump_fraction, cv::Mat* depth) {
  if (margin_px <= 0) return 0;
  cv::Mat farthest;  // unknown pixels are 0 and never the farthest
  cv::dilate(*depth, farthest,
             cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * margin_px + 1, 2 * margin_px + 1)));
  return ClearKnownDepthsWhere(farthest > *depth * (1.0 + jump_fraction), depth);
}

cv::Mat CombinePairDepthMaps(const std::vector<cv::Mat>& pairs, const ProxyOptions& options) {
  RELIT_REQUIRE(!pairs.empty(), "CombinePairDepthMaps: no depth maps");
  cv::Mat depth(pairs[0].rows, pairs[0].cols, CV_32F, cv::Scalar(0));
  std::vector<float> values;
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      values.clear();
      for (const cv::Mat& pair : pairs) {
        if (pair.at<float>(v, u) > 0) values.push_back(pair.at<float>(v, u));
      }
      if (values.empty()) continue;
      // The value most others agree with; the mean of that group.
      int best_count = -1;
      double best_mean = 0;
      for (const float a : values) {
        int count = 0;
        double sum = 0;
        for (const float b : values) {
          if (std::abs(a - b) <= options.depth_tolerance * a) {
            ++count;
            sum += b;
          }
        }
        if (count > best_count) {
          best_count = count;
          best_mean = sum / count;
        }
      }
      if (values.size() >= 2 && best_count < 2) continue;  // the pairs disagree
      depth.at<float>(v, u) = static_cast<float>(best_mean);
    }
  }
  return depth;
}

}  // namespace relit::reconstruct
