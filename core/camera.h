// Camera model shared by every stage.
//
// Conventions (see docs/conventions.md):
// - World frame: the ChArUco board frame converted to +Z up (away from the
//   table), metres. See WorldFromBoard in board.h.
// - Camera frame: OpenCV, x right, y down, z forward (optical axis), metres.
// - Pixels: OpenCV convention, the centre of the top-left pixel is (0, 0);
//   pixel (i, j) covers [i-0.5, i+0.5] x [j-0.5, j+0.5].
// - Distortion: OpenCV's 5-parameter model (k1, k2, p1, p2, k3) applied to
//   normalised image coordinates.
#pragma once

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace relit {

// A rigid transform y = rotation * x + translation. Named by what it maps:
// cam_from_world maps world points into the camera frame.
struct Rigid3 {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3() = default;
  Rigid3(const Eigen::Quaterniond& r, const Eigen::Vector3d& t)
      : rotation(r.normalized()), translation(t) {}
  Rigid3(const Eigen::Matrix3d& r, const Eigen::Vector3d& t)
      : rotation(Eigen::Quaterniond(r).normalized()), translation(t) {}

  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const {
    return rotation * x + translation;
  }
  Rigid3 operator*(const Rigid3& other) const {
    return Rigid3(rotation * other.rotation,
                  rotation * other.translation + translation);
  }
  Rigid3 Inverse() const {
    const Eigen::Quaterniond inv = rotation.conjugate();
    return Rigid3(inv, -(inv * translation));
  }
  Eigen::Matrix4d ToMatrix() const;
  static Rigid3 FromMatrix(const Eigen::Matrix4d& m);
};

// Rotation angle in radians between two rotations.
double RotationAngle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);

// Builds cam_from_world for a camera at `eye` looking at `target`, with the
// image "up" direction as close to `up_world` as possible (OpenCV: image y
// runs down, so camera -y maps to up_world).
Rigid3 LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
              const Eigen::Vector3d& up_world);

struct Distortion {
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;
  bool IsZero() const { return k1 == 0 && k2 == 0 && p1 == 0 && p2 == 0 && k3 == 0; }
};

// The largest camera image relit accepts (an 8K frame is 33 megapixels).
inline constexpr int kMaxImageSidePx = 16384;
inline constexpr int64_t kMaxImagePixels = int64_t{1} << 26;

struct Intrinsics {
  int width = 0;   // pixels
  int height = 0;  // pixels
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels
  Distortion distortion;

  // Pinhole intrinsics for an image of the given size with a horizontal
  // field of view in radians, principal point at the image centre.
  static Intrinsics FromFov(int width, int height, double horizontal_fov_rad);

  // Throws relit::Error when sizes or focal lengths are not positive.
  void Check() const;

  // Same camera at a different resolution (focal lengths and principal point
  // scaled so the field of view is preserved, pixel-centre convention kept).
  Intrinsics Scaled(int new_width, int new_height) const;

  Intrinsics WithoutDistortion() const {
    Intrinsics copy = *this;
    copy.distortion = Distortion{};
    return copy;
  }

  cv::Matx33d CameraMatrix() const;
  cv::Mat DistortionCoefficients() const;  // 1x5 CV_64F (k1,k2,p1,p2,k3)
};

// Applies the lens distortion to normalised coordinates (x/z, y/z).
Eigen::Vector2d Distort(const Distortion& d, const Eigen::Vector2d& normalized);
// Inverts Distort by Newton iterations; accurate to ~1e-12 for the
// distortion strengths of phone lenses.
Eigen::Vector2d Undistort(const Distortion& d, const Eigen::Vector2d& distorted);

class Camera {
 public:
  Camera() = default;
  Camera(const Intrinsics& intrinsics, const Rigid3& cam_from_world)
      : intrinsics_(intrinsics), cam_from_world_(cam_from_world) {}

  const Intrinsics& intrinsics() const { return intrinsics_; }
  const Rigid3& cam_from_world() const { return cam_from_world_; }
  Rigid3 world_from_cam() const { return cam_from_world_.Inverse(); }
  Eigen::Vector3d Center() const { return world_from_cam().translation; }
  // Unit optical axis (+z of the camera) in world coordinates.
  Eigen::Vector3d ViewDirection() const;

  // Projects a world point to distorted pixel coordinates. Returns false when
  // the point is behind (or on) the camera plane.
  bool Project(const Eigen::Vector3d& point_world, Eigen::Vector2d* pixel) const;
  // Projects a camera-frame point (no behind-camera check).
  Eigen::Vector2d ProjectCameraPoint(const Eigen::Vector3d& point_cam) const;

  // Unit ray direction in the camera frame through a (distorted) pixel.
  Eigen::Vector3d PixelToCameraRay(const Eigen::Vector2d& pixel) const;
  // Unit ray direction in world coordinates through a (distorted) pixel; the
  // ray starts at Center().
  Eigen::Vector3d PixelToWorldRay(const Eigen::Vector2d& pixel) const;

 private:
  Intrinsics intrinsics_;
  Rigid3 cam_from_world_;
};

// Maps for cv::remap that turn an image taken with `distorted` into one taken
// by the pinhole camera `pinhole` (same orientation). CV_32FC1 x and y maps.
void UndistortionMaps(const Intrinsics& distorted, const Intrinsics& pinhole,
                      cv::Mat* map_x, cv::Mat* map_y);

}  // namespace relit
