#include "core/camera.h"

#include <cmath>
#include <opencv2/calib3d.hpp>

#include "core/error.h"

namespace relit {

Eigen::Matrix4d Rigid3::ToMatrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = rotation.toRotationMatrix();
  m.topRightCorner<3, 1>() = translation;
  return m;
}

Rigid3 Rigid3::FromMatrix(const Eigen::Matrix4d& m) {
  return Rigid3(Eigen::Matrix3d(m.topLeftCorner<3, 3>()),
                Eigen::Vector3d(m.topRightCorner<3, 1>()));
}

double RotationAngle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b);
}

Rigid3 LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
              const Eigen::Vector3d& up_world) {
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d x = z.cross(up_world);  // camera x: right
  if (x.norm() < 1e-9) {
    // Looking straight along up: pick any perpendicular right vector.
    x = z.unitOrthogonal();
  }
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);  // camera y: down
  Eigen::Matrix3d world_from_cam_rotation;
  world_from_cam_rotation.col(0) = x;
  world_from_cam_rotation.col(1) = y;
  world_from_cam_rotation.col(2) = z;
  const Eigen::Matrix3d r = world_from_cam_rotation.transpose();
  return Rigid3(r, -(r * eye));
}

Intrinsics Intrinsics::FromFov(int width, int height, double horizontal_fov_rad) {
  Intrinsics k;
  k.width = width;
  k.height = height;
  k.fx = k.fy = 0.5 * width / std::tan(0.5 * horizontal_fov_rad);
  k.cx = 0.5 * width - 0.5;
  k.cy = 0.5 * height - 0.5;
  return k;
}

void Intrinsics::Check() const {
  RELIT_REQUIRE(width > 0 && height > 0, "camera size must be positive, got ",
                width, "x", height, " pixels");
  // Every image of a camera is allocated at this size: a typo such as
  // 100000 x 100000 would exhaust memory instead of failing.
  RELIT_REQUIRE(width <= kMaxImageSidePx && height <= kMaxImageSidePx &&
                    static_cast<int64_t>(width) * height <= kMaxImagePixels,
                "camera size ", width, "x", height, " pixels is larger than relit handles (sides up to ",
                kMaxImageSidePx, ", ", kMaxImagePixels / 1000000, " megapixels): check width and height");
  RELIT_REQUIRE(fx > 0 && fy > 0 && std::isfinite(fx) && std::isfinite(fy),
                "camera focal lengths must be positive, got fx=", fx, " fy=", fy);
  RELIT_REQUIRE(std::isfinite(cx) && std::isfinite(cy),
                "camera principal point is not finite");
}

Intrinsics Intrinsics::Scaled(int new_width, int new_height) const {
  Intrinsics k = *this;
  const double sx = static_cast<double>(new_width) / width;
  const double sy = static_cast<double>(new_height) / height;
  k.width = new_width;
  k.height = new_height;
  k.fx *= sx;
  k.fy *= sy;
  // Pixel centres at integers: edges at -0.5 map to -0.5.
  k.cx = (cx + 0.5) * sx - 0.5;
  k.cy = (cy + 0.5) * sy - 0.5;
  return k;
}

cv::Matx33d Intrinsics::CameraMatrix() const {
  return cv::Matx33d(fx, 0, cx, 0, fy, cy, 0, 0, 1);
}

cv::Mat Intrinsics::DistortionCoefficients() const {
  cv::Mat d(1, 5, CV_64F);
  d.at<double>(0) = distortion.k1;
  d.at<double>(1) = distortion.k2;
  d.at<double>(2) = distortion.p1;
  d.at<double>(3) = distortion.p2;
  d.at<double>(4) = distortion.k3;
  return d;
}

Eigen::Vector2d Distort(const Distortion& d, const Eigen::Vector2d& n) {
  const double x = n.x(), y = n.y();
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3));
  const double xd = x * radial + 2 * d.p1 * x * y + d.p2 * (r2 + 2 * x * x);
  const double yd = y * radial + d.p1 * (r2 + 2 * y * y) + 2 * d.p2 * x * y;
  return {xd, yd};
}

Eigen::Vector2d Undistort(const Distortion& d, const Eigen::Vector2d& distorted) {
  if (d.IsZero()) return distorted;
  // Newton's method on Distort(n) - distorted = 0 with a numeric Jacobian;
  // starts from the distorted point, which is close for phone lenses.
  Eigen::Vector2d n = distorted;
  for (int iter = 0; iter < 50; ++iter) {
    const Eigen::Vector2d residual = Distort(d, n) - distorted;
    if (residual.squaredNorm() < 1e-28) break;
    const double h = 1e-7;
    Eigen::Matrix2d jacobian;
    jacobian.col(0) = (Distort(d, n + Eigen::Vector2d(h, 0)) - Distort(d, n - Eigen::Vector2d(h, 0))) / (2 * h);
    jacobian.col(1) = (Distort(d, n + Eigen::Vector2d(0, h)) - Distort(d, n - Eigen::Vector2d(0, h))) / (2 * h);
    n -= jacobian.partialPivLu().solve(residual);
  }
  return n;
}

Eigen::Vector3d Camera::ViewDirection() const {
  return cam_from_world_.rotation.conjugate() * Eigen::Vector3d::UnitZ();
}

Eigen::Vector2d Camera::ProjectCameraPoint(const Eigen::Vector3d& p) const {
  const Intrinsics& k = intrinsics_;
  const Eigen::Vector2d n = Distort(k.distortion, Eigen::Vector2d(p.x() / p.z(), p.y() / p.z()));
  return {k.fx * n.x() + k.cx, k.fy * n.y() + k.cy};
}

bool Camera::Project(const Eigen::Vector3d& point_world, Eigen::Vector2d* pixel) const {
  const Eigen::Vector3d p = cam_from_world_ * point_world;
  if (p.z() <= 1e-12) return false;
  *pixel = ProjectCameraPoint(p);
  return true;
}

Eigen::Vector3d Camera::PixelToCameraRay(const Eigen::Vector2d& pixel) const {
  const Intrinsics& k = intrinsics_;
  const Eigen::Vector2d distorted((pixel.x() - k.cx) / k.fx, (pixel.y() - k.cy) / k.fy);
  const Eigen::Vector2d n = Undistort(k.distortion, distorted);
  return Eigen::Vector3d(n.x(), n.y(), 1.0).normalized();
}

Eigen::Vector3d Camera::PixelToWorldRay(const Eigen::Vector2d& pixel) const {
  return cam_from_world_.rotation.conjugate() * PixelToCameraRay(pixel);
}

void UndistortionMaps(const Intrinsics& distorted, const Intrinsics& pinhole,
                      cv::Mat* map_x, cv::Mat* map_y) {
  distorted.Check();
  pinhole.Check();
  cv::initUndistortRectifyMap(distorted.CameraMatrix(), distorted.DistortionCoefficients(),
                              cv::Matx33d::eye(), pinhole.CameraMatrix(),
                              cv::Size(pinhole.width, pinhole.height), CV_32FC1,
                              *map_x, *map_y);
}

}  // namespace relit
