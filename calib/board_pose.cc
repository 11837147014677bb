#include "calib/board_pose.h"

#include <algorithm>
#include <cmath>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "core/error.h"
#include "core/median.h"

namespace relit::calib {

namespace {

Eigen::Matrix3d RotationFromRvec(const cv::Mat& rvec) {
  cv::Mat r;
  cv::Rodrigues(rvec, r);
  Eigen::Matrix3d m;
  cv::cv2eigen(r, m);
  return m;
}

}  // namespace

BoardCalibration CalibrateFromBoard(const std::vector<const BoardObservation*>& observations,
                                    const BoardSpec& spec, int width, int height, bool refine_k3, bool square_pixels,
                                    bool refine_tangential,
                                    int min_corners, int max_frames, const std::string& device) {
  std::vector<const BoardObservation*> usable;
  for (const BoardObservation* o : observations) {
    if (static_cast<int>(o->corner_ids.size()) >= min_corners) usable.push_back(o);
  }
  RELIT_REQUIRE(usable.size() >= 3, "phone ", device, ": only ", usable.size(), " of ",
                observations.size(), " frames show at least ", min_corners,
                " ChArUco corners; at least 3 are needed to calibrate its lens. Film the board "
                "larger and from several angles");
  std::vector<const BoardObservation*> chosen;
  if (static_cast<int>(usable.size()) <= max_frames) {
    chosen = usable;
  } else {
    for (int i = 0; i < max_frames; ++i) chosen.push_back(usable[i * usable.size() / max_frames]);
  }
  // Each round judges every detected corner of the frames still in use
  // against the latest fit, so a corner dropped while outliers pulled the
  // first fit comes back.
  std::vector<std::vector<cv::Point2f>> detected;
  std::vector<std::vector<int>> detected_ids;
  for (const BoardObservation* o : chosen) {
    std::vector<cv::Point2f> c;
    for (const Eigen::Vector2d& p : o->corners_px) c.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
    detected.push_back(c);
    detected_ids.push_back(o->corner_ids);
  }
  const auto board = MakeCharucoBoard(spec);
  int flags = cv::CALIB_USE_INTRINSIC_GUESS;
  if (!refine_k3) flags |= cv::CALIB_FIX_K3;
  if (square_pixels) flags |= cv::CALIB_FIX_ASPECT_RATIO;
  if (!refine_tangential) flags |= cv::CALIB_ZERO_TANGENT_DIST;
  BoardCalibration result;
  cv::Mat k, dist;
  std::vector<cv::Mat> rvecs, tvecs;
  std::vector<std::vector<cv::Point2f>> corners = detected;  // the frames and corners in use
  std::vector<std::vector<int>> ids = detected_ids;
  std::vector<size_t> frame_of(detected.size());
  for (size_t f = 0; f < frame_of.size(); ++f) frame_of[f] = f;
  for (int round = 0; round < 5; ++round) {
    // Start from a 65 degree field of view, centred: phone main cameras.
    const double f0 = 0.5 * width / std::tan(0.5 * 65.0 * M_PI / 180.0);
    k = (cv::Mat_<double>(3, 3) << f0, 0, 0.5 * (width - 1), 0, f0, 0.5 * (height - 1), 0, 0, 1);
    dist = cv::Mat::zeros(1, 5, CV_64F);
    result.rms_px = cv::aruco::calibrateCameraCharuco(corners, ids, board, cv::Size(width, height), k, dist,
                                                      rvecs, tvecs, flags);
    if (round == 4) break;
    std::vector<std::vector<double>> errors(frame_of.size());
    std::vector<double> all;
    for (size_t f = 0; f < frame_of.size(); ++f) {
      std::vector<cv::Point3f> object;
      for (int id : detected_ids[frame_of[f]]) object.push_back(board->chessboardCorners[id]);
      std::vector<cv::Point2f> projected;
      cv::projectPoints(object, rvecs[f], tvecs[f], k, dist, projected);
      for (size_t i = 0; i < projected.size(); ++i) {
        errors[f].push_back(cv::norm(projected[i] - detected[frame_of[f]][i]));
        all.push_back(errors[f].back());
      }
    }
    const double threshold = std::max(0.5, 3 * 1.4826 * Median(std::move(all)));
    bool changed = false;
    std::vector<std::vector<cv::Point2f>> kept_corners;
    std::vector<std::vector<int>> kept_ids;
    std::vector<size_t> kept_frames;
    for (size_t f = 0; f < frame_of.size(); ++f) {
      std::vector<cv::Point2f> c;
      std::vector<int> id;
      for (size_t i = 0; i < errors[f].size(); ++i) {
        if (errors[f][i] <= threshold) {
          c.push_back(detected[frame_of[f]][i]);
          id.push_back(detected_ids[frame_of[f]][i]);
        }
      }
      changed = changed || id != ids[f];
      // A frame left with too few corners would only add an unconstrained pose.
      if (static_cast<int>(id.size()) < std::max(4, min_corners)) continue;
      kept_corners.push_back(c);
      kept_ids.push_back(id);
      kept_frames.push_back(frame_of[f]);
    }
    if (!changed) break;
    RELIT_REQUIRE(kept_frames.size() >= 3, "phone ", device, ": only ", kept_frames.size(),
                  " frames keep enough ChArUco corners after dropping outliers; film the board "
                  "sharper and larger");
    corners = kept_corners;
    ids = kept_ids;
    frame_of = kept_frames;
  }
  for (const auto& frame_ids : ids) result.corners_used += static_cast<int>(frame_ids.size());
  for (const auto& frame_ids : detected_ids) result.corners_rejected += static_cast<int>(frame_ids.size());
  result.corners_rejected -= result.corners_used;
  result.frames_used = static_cast<int>(corners.size());
  // Degenerate motion: a lens needs board views from different directions.
  std::vector<Eigen::Vector3d> normals;
  for (const cv::Mat& r : rvecs) normals.push_back(RotationFromRvec(r).col(2));
  for (size_t i = 0; i < normals.size(); ++i) {
    for (size_t j = i + 1; j < normals.size(); ++j) {
      const double c = std::clamp(normals[i].dot(normals[j]), -1.0, 1.0);
      result.view_angle_span_deg = std::max(result.view_angle_span_deg, std::acos(c) * 180.0 / M_PI);
    }
  }
  RELIT_REQUIRE(result.view_angle_span_deg >= 10.0, "phone ", device,
                ": degenerate motion, all board views lie within ",
                result.view_angle_span_deg, " degrees of each other; the lens (focal length) "
                "cannot be calibrated. Move around the object, tilting the phone");
  Intrinsics& in = result.intrinsics;
  in.width = width;
  in.height = height;
  in.fx = k.at<double>(0, 0);
  in.fy = k.at<double>(1, 1);
  in.cx = k.at<double>(0, 2);
  in.cy = k.at<double>(1, 2);
  in.distortion = {dist.at<double>(0), dist.at<double>(1), dist.at<double>(2), dist.at<double>(3),
                   dist.at<double>(4)};
  RELIT_REQUIRE(std::isfinite(in.fx) && in.fx > 0 && in.fy > 0 && std::isfinite(result.rms_px),
                "phone ", device, ": board calibration failed (focal length ", in.fx, ")");
  return result;
}

bool BoardPose(const BoardObservation& observation, const Intrinsics& intrinsics,
               const BoardSpec& spec, int min_corners, Rigid3* cam_from_world, double* rms_px) {
  if (static_cast<int>(observation.corner_ids.size()) < std::max(4, min_corners)) return false;
  static thread_local BoardSpec cached_spec;
  static thread_local std::vector<Eigen::Vector3d> corners_world;
  if (corners_world.empty() || cached_spec.squares_x != spec.squares_x ||
      cached_spec.squares_y != spec.squares_y || cached_spec.square_length_m != spec.square_length_m ||
      cached_spec.marker_length_m != spec.marker_length_m || cached_spec.dictionary != spec.dictionary) {
    corners_world = CharucoCornersWorld(spec);
    cached_spec = spec;
  }
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (size_t i = 0; i < observation.corner_ids.size(); ++i) {
    const Eigen::Vector3d& p = corners_world.at(observation.corner_ids[i]);
    object.emplace_back(p.x(), p.y(), p.z());
    image.emplace_back(observation.corners_px[i].x(), observation.corners_px[i].y());
  }
  const cv::Matx33d k = intrinsics.CameraMatrix();
  const cv::Mat dist = intrinsics.DistortionCoefficients();
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(object, image, k, dist, rvec, tvec, false, cv::SOLVEPNP_IPPE)) return false;
  cv::solvePnPRefineLM(object, image, k, dist, rvec, tvec);
  std::vector<cv::Point2d> projected;
  cv::projectPoints(object, rvec, tvec, k, dist, projected);
  double sum = 0;
  for (size_t i = 0; i < image.size(); ++i) {
    const cv::Point2d d = projected[i] - image[i];
    sum += d.dot(d);
  }
  if (rms_px) *rms_px = std::sqrt(sum / image.size());
  const Eigen::Vector3d t(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  if (!(t.z() > 0) || !t.allFinite()) return false;  // the board must be in front of the camera
  *cam_from_world = Rigid3(RotationFromRvec(rvec), t);
  return true;
}

}  // namespace relit::calib
