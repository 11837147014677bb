#include "core/camera.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

namespace relit {
namespace {

Intrinsics PhoneIntrinsics() {
  Intrinsics k = Intrinsics::FromFov(640, 480, 65.0 * M_PI / 180.0);
  k.cx += 3.2;
  k.cy -= 2.1;
  k.distortion = {0.12, -0.25, 0.001, -0.0015, 0.1};
  return k;
}

TEST(Rigid3, InverseAndCompose) {
  const Rigid3 a(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
                 Eigen::Vector3d(0.1, -0.2, 0.5));
  const Eigen::Vector3d p(0.3, 0.4, -0.2);
  EXPECT_LT(((a.Inverse() * a) * p - p).norm(), 1e-12);
  EXPECT_LT((Rigid3::FromMatrix(a.ToMatrix()) * p - a * p).norm(), 1e-12);
}

TEST(Camera, LookAtPutsTargetOnAxisAndUpIsUp) {
  const Rigid3 cam_from_world = LookAt({0.4, -0.3, 0.5}, {0, 0, 0.05}, {0, 0, 1});
  const Eigen::Vector3d target_cam = cam_from_world * Eigen::Vector3d(0, 0, 0.05);
  EXPECT_NEAR(target_cam.x(), 0, 1e-12);
  EXPECT_NEAR(target_cam.y(), 0, 1e-12);
  EXPECT_GT(target_cam.z(), 0);
  // A point above the target appears higher in the image (smaller y).
  const Eigen::Vector3d above_cam = cam_from_world * Eigen::Vector3d(0, 0, 0.15);
  EXPECT_LT(above_cam.y(), 0);
}

TEST(Camera, ProjectMatchesOpenCv) {
  const Intrinsics k = PhoneIntrinsics();
  const Rigid3 cam_from_world = LookAt({0.3, 0.2, 0.4}, {0, 0, 0}, {0, 0, 1});
  const Camera camera(k, cam_from_world);
  std::vector<cv::Point3d> points;
  for (int i = 0; i < 20; ++i) points.emplace_back(-0.1 + 0.01 * i, 0.05 - 0.005 * i, 0.002 * i);
  const Eigen::AngleAxisd aa(cam_from_world.rotation);
  const Eigen::Vector3d rvec_e = aa.angle() * aa.axis();
  const cv::Vec3d rvec(rvec_e.x(), rvec_e.y(), rvec_e.z());
  const cv::Vec3d tvec(cam_from_world.translation.x(), cam_from_world.translation.y(),
                       cam_from_world.translation.z());
  std::vector<cv::Point2d> expected;
  cv::projectPoints(points, rvec, tvec, k.CameraMatrix(), k.DistortionCoefficients(), expected);
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(camera.Project({points[i].x, points[i].y, points[i].z}, &pixel));
    EXPECT_NEAR(pixel.x(), expected[i].x, 1e-9);
    EXPECT_NEAR(pixel.y(), expected[i].y, 1e-9);
  }
}

TEST(Camera, UnprojectInvertsProject) {
  const Camera camera(PhoneIntrinsics(), LookAt({0.3, 0.2, 0.4}, {0, 0, 0}, {0, 0, 1}));
  for (double x : {0.0, 100.5, 320.0, 639.0}) {
    for (double y : {0.0, 240.0, 479.0}) {
      const Eigen::Vector3d ray = camera.PixelToWorldRay({x, y});
      Eigen::Vector2d pixel;
      ASSERT_TRUE(camera.Project(camera.Center() + 0.5 * ray, &pixel));
      EXPECT_NEAR(pixel.x(), x, 1e-7);
      EXPECT_NEAR(pixel.y(), y, 1e-7);
    }
  }
}

TEST(Camera, BehindCameraIsRejected) {
  const Camera camera(PhoneIntrinsics(), Rigid3());
  Eigen::Vector2d pixel;
  EXPECT_FALSE(camera.Project({0, 0, -1}, &pixel));
}

TEST(Camera, ScaledKeepsFieldOfView) {
  const Intrinsics k = PhoneIntrinsics();
  const Intrinsics half = k.Scaled(320, 240);
  const Camera full_camera(k, Rigid3()), half_camera(half, Rigid3());
  Eigen::Vector2d a, b;
  ASSERT_TRUE(full_camera.Project({0.1, 0.05, 1}, &a));
  ASSERT_TRUE(half_camera.Project({0.1, 0.05, 1}, &b));
  EXPECT_NEAR((a.x() + 0.5) / 2 - 0.5, b.x(), 1e-9);
  EXPECT_NEAR((a.y() + 0.5) / 2 - 0.5, b.y(), 1e-9);
}

TEST(Camera, UndistortionMapsAgreeWithModel) {
  const Intrinsics k = PhoneIntrinsics();
  const Intrinsics pinhole = k.WithoutDistortion();
  cv::Mat map_x, map_y;
  UndistortionMaps(k, pinhole, &map_x, &map_y);
  const Camera distorted(k, Rigid3()), ideal(pinhole, Rigid3());
  for (int y : {10, 240, 470}) {
    for (int x : {10, 320, 630}) {
      // Pinhole pixel (x, y) must come from where the distorted camera sees the same ray.
      const Eigen::Vector3d ray = ideal.PixelToCameraRay({double(x), double(y)});
      const Eigen::Vector2d source = distorted.ProjectCameraPoint(ray);
      EXPECT_NEAR(map_x.at<float>(y, x), source.x(), 2e-3);
      EXPECT_NEAR(map_y.at<float>(y, x), source.y(), 2e-3);
    }
  }
}

TEST(Intrinsics, CheckRejectsNonsense) {
  Intrinsics k;
  EXPECT_THROW(k.Check(), std::runtime_error);
}

}  // namespace
}  // namespace relit
