#include "calib/board_detect.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <set>

#include <opencv2/aruco.hpp>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag16h5.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h10.h>
#include <apriltag/tag36h11.h>
}

#include "core/error.h"
#include "core/median.h"

namespace relit::calib {

namespace {

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

apriltag_family_t* CreateFamily(const std::string& name) {
  if (name == "tag36h11") return tag36h11_create();
  if (name == "tag36h10") return tag36h10_create();
  if (name == "tag25h9") return tag25h9_create();
  if (name == "tag16h5") return tag16h5_create();
  return nullptr;
}

void DestroyFamily(const std::string& name, apriltag_family_t* family) {
  if (name == "tag36h11") tag36h11_destroy(family);
  if (name == "tag36h10") tag36h10_destroy(family);
  if (name == "tag25h9") tag25h9_destroy(family);
  if (name == "tag16h5") tag16h5_destroy(family);
}

}  // namespace

std::string AprilTagFamily(const std::string& dictionary) {
  if (dictionary == "DICT_APRILTAG_36h11") return "tag36h11";
  if (dictionary == "DICT_APRILTAG_36h10") return "tag36h10";
  if (dictionary == "DICT_APRILTAG_25h9") return "tag25h9";
  if (dictionary == "DICT_APRILTAG_16h5") return "tag16h5";
  return "";
}

struct BoardDetector::Impl {
  BoardSpec spec;
  DetectOptions options;
  cv::Ptr<cv::aruco::CharucoBoard> board;
  cv::Ptr<cv::aruco::DetectorParameters> parameters;
  std::string family_name;
  // libapriltag detectors are not thread-safe: a pool, one per concurrent call.
  apriltag_family_t* family = nullptr;
  mutable std::mutex pool_mutex;
  mutable std::vector<apriltag_detector_t*> pool;

  apriltag_detector_t* Acquire() const {
    {
      std::lock_guard<std::mutex> lock(pool_mutex);
      if (!pool.empty()) {
        apriltag_detector_t* detector = pool.back();
        pool.pop_back();
        return detector;
      }
    }
    apriltag_detector_t* detector = apriltag_detector_create();
    apriltag_detector_add_family_bits(detector, family, 1);
    detector->quad_decimate = 1.0f;  // phone frames are small already
    detector->quad_sigma = 0.0f;
    detector->refine_edges = 1;
    detector->nthreads = 1;          // frames run in parallel instead
    return detector;
  }
  void Release(apriltag_detector_t* detector) const {
    std::lock_guard<std::mutex> lock(pool_mutex);
    pool.push_back(detector);
  }
};

BoardDetector::BoardDetector(const BoardSpec& spec, const DetectOptions& options)
    : impl_(std::make_unique<Impl>()) {
  impl_->spec = spec;
  impl_->options = options;
  impl_->board = MakeCharucoBoard(spec);
  impl_->parameters = cv::aruco::DetectorParameters::create();
  impl_->parameters->cornerRefinementMethod = cv::aruco::CORNER_REFINE_SUBPIX;
  impl_->parameters->cornerRefinementWinSize = 3;
  impl_->family_name = AprilTagFamily(spec.dictionary);
  if (!impl_->family_name.empty()) impl_->family = CreateFamily(impl_->family_name);
}

BoardDetector::~BoardDetector() {
  for (apriltag_detector_t* detector : impl_->pool) apriltag_detector_destroy(detector);
  if (impl_->family) DestroyFamily(impl_->family_name, impl_->family);
}

bool BoardDetector::apriltag_available() const { return impl_->family != nullptr; }

int BoardDetector::marker_count() const { return static_cast<int>(impl_->board->ids.size()); }

std::vector<MarkerCorners> BoardDetector::DetectOpenCv(const cv::Mat& grey, int* rejected_count) const {
  std::vector<int> ids;
  std::vector<std::vector<cv::Point2f>> corners, rejected;
  const cv::Ptr<cv::aruco::Board> board = impl_->board.staticCast<cv::aruco::Board>();
  cv::aruco::detectMarkers(grey, impl_->board->dictionary, corners, ids, impl_->parameters, rejected);
  if (!ids.empty()) {
    cv::aruco::refineDetectedMarkers(grey, board, corners, ids, rejected, cv::noArray(),
                                     cv::noArray(), 10.0f, 3.0f, true, cv::noArray(),
                                     impl_->parameters);
  }
  if (rejected_count) *rejected_count = static_cast<int>(rejected.size());
  std::vector<MarkerCorners> markers;
  for (size_t i = 0; i < ids.size(); ++i) {
    MarkerCorners m;
    m.id = ids[i];
    for (int k = 0; k < 4; ++k) m.corners_px[k] = Eigen::Vector2d(corners[i][k].x, corners[i][k].y);
    markers.push_back(m);
  }
  return markers;
}

std::vector<MarkerCorners> BoardDetector::DetectAprilTag(const cv::Mat& grey) const {
  std::vector<MarkerCorners> markers;
  if (!impl_->family) return markers;
  RELIT_CHECK(grey.type() == CV_8UC1 && grey.isContinuous());
  apriltag_detector_t* detector = impl_->Acquire();
  image_u8_t image{grey.cols, grey.rows, static_cast<int32_t>(grey.step), grey.data};
  zarray_t* detections = apriltag_detector_detect(detector, &image);
  const int board_markers = marker_count();
  for (int i = 0; i < zarray_size(detections); ++i) {
    apriltag_detection_t* d = nullptr;
    zarray_get(detections, i, &d);
    if (d->hamming > 1 || d->id >= board_markers) continue;
    // libapriltag wraps the corners the other way round: OpenCV's corner k
    // is libapriltag's corner kOrder[k] (checked in calib_unit_test).
    static constexpr int kOrder[4] = {1, 0, 3, 2};
    MarkerCorners m;
    m.id = d->id;
    for (int k = 0; k < 4; ++k) m.corners_px[k] = Eigen::Vector2d(d->p[kOrder[k]][0], d->p[kOrder[k]][1]);
    markers.push_back(m);
  }
  apriltag_detections_destroy(detections);
  impl_->Release(detector);
  return markers;
}

BoardObservation BoardDetector::Detect(const cv::Mat& grey) const {
  BoardObservation obs;
  const DetectOptions& o = impl_->options;
  auto start = std::chrono::steady_clock::now();
  obs.markers = DetectOpenCv(grey, &obs.rejected_candidates);
  obs.opencv_ms = MillisecondsSince(start);
  obs.markers_opencv = static_cast<int>(obs.markers.size());
  const bool run_apriltag =
      apriltag_available() &&
      (o.apriltag == "always" ||
       (o.apriltag == "second_pass" && obs.markers_opencv < o.apriltag_below_fraction * marker_count()));
  if (run_apriltag) {
    start = std::chrono::steady_clock::now();
    const std::vector<MarkerCorners> extra = DetectAprilTag(grey);
    obs.apriltag_ms = MillisecondsSince(start);
    obs.apriltag_ran = true;
    obs.markers_apriltag = static_cast<int>(extra.size());
    std::set<int> have;
    for (const MarkerCorners& m : obs.markers) have.insert(m.id);
    for (const MarkerCorners& m : extra) {
      if (have.insert(m.id).second) {
        obs.markers.push_back(m);
        ++obs.markers_apriltag_added;
      }
    }
  }
  if (obs.markers.empty()) return obs;

  start = std::chrono::steady_clock::now();
  std::vector<int> ids;
  std::vector<std::vector<cv::Point2f>> corners;
  for (const MarkerCorners& m : obs.markers) {
    ids.push_back(m.id);
    std::vector<cv::Point2f> c;
    for (const Eigen::Vector2d& p : m.corners_px) c.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
    corners.push_back(c);
  }
  std::vector<cv::Point2f> charuco_corners;
  std::vector<int> charuco_ids;
  cv::aruco::interpolateCornersCharuco(corners, ids, grey, impl_->board, charuco_corners, charuco_ids);
  // Corners next to a single found marker, only where the image shows a
  // chessboard corner, and only in frames that would otherwise have too few
  // corners for a pose (detect.min_adjacent_markers): elsewhere they cost
  // accuracy (docs/calib.md, "Partial boards").
  std::vector<cv::Point2f> single_corners;
  std::vector<int> single_ids;
  if (o.min_adjacent_markers == 1 && static_cast<int>(charuco_ids.size()) < o.min_corners) {
    std::vector<cv::Point2f> any_corners;
    std::vector<int> any_ids;
    cv::aruco::interpolateCornersCharuco(corners, ids, grey, impl_->board, any_corners, any_ids,
                                         cv::noArray(), cv::noArray(), 1);
    const std::set<int> have(charuco_ids.begin(), charuco_ids.end());
    for (size_t i = 0; i < any_ids.size(); ++i) {
      if (have.count(any_ids[i]) || XCornerContrast(grey, any_corners[i], 3.0) < o.single_marker_min_contrast) {
        continue;
      }
      single_corners.push_back(any_corners[i]);
      single_ids.push_back(any_ids[i]);
    }
  }
  // interpolateCornersCharuco stops at 0.1 px and keeps a bias from the
  // contour-based marker corners: refine once more (docs/synthetic.md).
  const int w = o.subpix_half_window_px;
  const cv::TermCriteria criteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3);
  // cornerSubPix, then with detect.corner_refine "saddle" the saddle fit,
  // which looks only at the pixels next to the corner (docs/calib.md,
  // "Sub-pixel corners").
  const bool saddle = o.corner_refine == "saddle";
  // From cornerSubPix's corner, the saddle fit may move this far; further
  // (small squares, where a marker's own X-junctions fall in its grid) it
  // has found another saddle and cornerSubPix's corner stays.
  constexpr double kSaddleMaxMovePx = 0.5;
  cv::Mat smooth;
  if (saddle) smooth = SaddleSmoothed(grey, o.saddle_sigma_px);
  auto refine = [&](std::vector<cv::Point2f>* points) {
    if (points->empty()) return;
    cv::cornerSubPix(grey, *points, cv::Size(w, w), cv::Size(-1, -1), criteria);
    if (saddle) SaddleRefine(smooth, o.saddle_half_window_px, kSaddleMaxMovePx, points);
  };
  refine(&charuco_corners);
  for (size_t i = 0; i < charuco_ids.size(); ++i) {
    obs.corner_ids.push_back(charuco_ids[i]);
    obs.corners_px.emplace_back(charuco_corners[i].x, charuco_corners[i].y);
  }
  if (!single_corners.empty()) {
    const std::vector<cv::Point2f> predicted = single_corners;
    refine(&single_corners);
    for (size_t i = 0; i < single_ids.size(); ++i) {
      if (cv::norm(single_corners[i] - predicted[i]) > 1.5) continue;  // drifted: not that corner
      obs.corner_ids.push_back(single_ids[i]);
      obs.corners_px.emplace_back(single_corners[i].x, single_corners[i].y);
      ++obs.corners_single_marker;
    }
  }
  obs.opencv_ms += MillisecondsSince(start);
  return obs;
}

cv::Mat SaddleSmoothed(const cv::Mat& grey, double sigma_px) {
  cv::Mat smooth;
  grey.convertTo(smooth, CV_32F);
  cv::GaussianBlur(smooth, smooth, cv::Size(0, 0), sigma_px);
  return smooth;
}

std::vector<bool> SaddleRefine(const cv::Mat& smooth, int half, double max_move_px,
                               std::vector<cv::Point2f>* corners) {
  RELIT_CHECK(smooth.type() == CV_32FC1 && half >= 1);
  const int n = 2 * half + 1;
  // Least-squares quadratic z = a x^2 + b xy + c y^2 + d x + e y + f on the
  // n x n grid of offsets -half..half around the current estimate.
  cv::Mat design(n * n, 6, CV_64F);
  for (int y = -half, r = 0; y <= half; ++y) {
    for (int x = -half; x <= half; ++x, ++r) {
      const double row[6] = {double(x * x), double(x * y), double(y * y), double(x), double(y), 1.0};
      for (int k = 0; k < 6; ++k) design.at<double>(r, k) = row[k];
    }
  }
  cv::Mat pinv;
  cv::invert(design, pinv, cv::DECOMP_SVD);
  cv::Mat patch, z(n * n, 1, CV_64F);
  std::vector<bool> moved(corners->size(), false);
  for (size_t i = 0; i < corners->size(); ++i) {
    cv::Point2f& corner = (*corners)[i];
    cv::Point2d p = corner;
    bool converged = false;
    for (int iteration = 0; iteration < 20 && !converged; ++iteration) {
      if (p.x < half + 1 || p.y < half + 1 || p.x > smooth.cols - half - 2 || p.y > smooth.rows - half - 2) break;
      cv::getRectSubPix(smooth, cv::Size(n, n), cv::Point2f(float(p.x), float(p.y)), patch, CV_32F);
      for (int r = 0; r < n * n; ++r) z.at<double>(r) = patch.at<float>(r / n, r % n);
      const cv::Mat q = pinv * z;
      const double a = q.at<double>(0), b = q.at<double>(1), c = q.at<double>(2);
      const double d = q.at<double>(3), e = q.at<double>(4);
      const double det = 4 * a * c - b * b;
      if (det >= 0) break;  // an extremum or an edge, not a chessboard corner
      // Stationary point of the quadratic: [2a b; b 2c] s = -[d; e].
      const cv::Point2d step((b * e - 2 * c * d) / det, (b * d - 2 * a * e) / det);
      if (std::hypot(step.x, step.y) > max_move_px) break;
      p += step;
      converged = std::hypot(step.x, step.y) < 1e-3;
    }
    // Not converged or walked off: keep the estimate it started from.
    if (converged && cv::norm(p - cv::Point2d(corner)) <= max_move_px) {
      corner = cv::Point2f(float(p.x), float(p.y));
      moved[i] = true;
    }
  }
  return moved;
}

double XCornerContrast(const cv::Mat& grey, const cv::Point2f& corner_px, double radius_px) {
  constexpr int kSamples = 32;
  std::vector<double> values(kSamples);
  for (int k = 0; k < kSamples; ++k) {
    const double a = 2 * M_PI * k / kSamples;
    const float x = static_cast<float>(corner_px.x + radius_px * std::cos(a));
    const float y = static_cast<float>(corner_px.y + radius_px * std::sin(a));
    if (x < 0 || y < 0 || x > grey.cols - 1 || y > grey.rows - 1) return 0;
    cv::Mat patch;
    cv::getRectSubPix(grey, cv::Size(1, 1), cv::Point2f(x, y), patch, CV_32F);
    values[k] = patch.at<float>(0, 0);
  }
  double mean = 0;
  for (double v : values) mean += v / kSamples;
  int transitions = 0;
  double bright = 0, dark = 0;
  int bright_count = 0, dark_count = 0;
  for (int k = 0; k < kSamples; ++k) {
    transitions += (values[k] > mean) != (values[(k + 1) % kSamples] > mean);
    if (values[k] > mean) {
      bright += values[k];
      ++bright_count;
    } else {
      dark += values[k];
      ++dark_count;
    }
  }
  if (transitions != 4 || bright_count == 0 || dark_count == 0) return 0;
  return bright / bright_count - dark / dark_count;
}

double MeasureMarkerRatio(const BoardObservation& obs, const Intrinsics& intrinsics,
                          const BoardSpec& spec) {
  if (obs.corner_ids.size() < 6 || obs.markers.empty()) return -1;
  const auto board = MakeCharucoBoard(spec);
  // Board-plane coordinates in units of squares, undistorted normalised image points.
  auto normalise = [&](const Eigen::Vector2d& px) {
    const Eigen::Vector2d d((px.x() - intrinsics.cx) / intrinsics.fx, (px.y() - intrinsics.cy) / intrinsics.fy);
    const Eigen::Vector2d u = Undistort(intrinsics.distortion, d);
    return cv::Point2d(u.x(), u.y());
  };
  std::vector<cv::Point2d> plane, image;
  for (size_t i = 0; i < obs.corner_ids.size(); ++i) {
    const cv::Point3f& p = board->chessboardCorners[obs.corner_ids[i]];
    plane.emplace_back(p.x / spec.square_length_m, p.y / spec.square_length_m);
    image.push_back(normalise(obs.corners_px[i]));
  }
  const cv::Mat h = cv::findHomography(image, plane, 0);
  if (h.empty()) return -1;
  std::vector<double> ratios;
  for (const MarkerCorners& m : obs.markers) {
    std::vector<cv::Point2d> in, out;
    for (const Eigen::Vector2d& c : m.corners_px) in.push_back(normalise(c));
    cv::perspectiveTransform(in, out, h);
    double side = 0;
    for (int k = 0; k < 4; ++k) side += cv::norm(out[k] - out[(k + 1) % 4]);
    ratios.push_back(side / 4);
  }
  return Median(std::move(ratios));
}

}  // namespace relit::calib
