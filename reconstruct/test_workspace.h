// Test fixture: a workspace with calib/cameras.json built from the synthetic
// spot capture's ground truth (tiny size), undistorted phone V frames
// rendered with pinhole cameras by the relit path tracer under the frame's
// flash light, and the ground-truth alpha of each frame. Stands in for the
// calib stage's output until calib exists. Test-only code.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/render/mesh.h"
#include "core/workspace.h"

namespace relit::reconstruct::testing {

struct TestWorkspace {
  std::string dir;                          // the workspace W
  CamerasFile cameras;
  std::vector<cv::Mat> truth_alpha;         // CV_32F per frame, same order as cameras.frames
  render::TriangleMesh truth_mesh;          // foreground objects, world frame
  std::string user_mesh;                    // W/user_mesh.obj: truth + board + table (a "scan")
  // W/rough_mesh.obj: like user_mesh, but the object inflated along its
  // normals by `rough_offset_m`, as a smooth stereo/Poisson proxy would be.
  std::string rough_mesh;
};

// Renders `frames` phone V frames spread over the tiny spot capture, and
// `geometry_frames` frames of its geometry pass (device "geometry", phone V's
// undistorted camera, soft ambient room light as relit-synth renders it).
TestWorkspace MakeTestWorkspace(const std::string& dir, int frames, int samples_per_pixel = 16,
                                double rough_offset_m = 0.003, int geometry_frames = 0);

// MakeTestWorkspace in ::testing::TempDir()/<name>_<pid>, rendered on the
// first call of the process (CTest runs each test case in its own process,
// maybe concurrently: hence the pid) and removed at exit. Later calls return
// the same workspace whatever their arguments.
const TestWorkspace& SharedTestWorkspace(const std::string& name, int frames, int samples_per_pixel = 16,
                                         double rough_offset_m = 0.003, int geometry_frames = 0);

// A pinhole camera (focal length focal_px, principal point at the image
// centre, no distortion) at `eye` looking at `target`, image up = +Z: the
// analytic test scenes' cameras.
// Ray parameter of the nearer intersection of a unit ray with a sphere
// (negative when the ray's line misses it or it lies behind the origin).
double RaySphere(const Eigen::Vector3d& origin, const Eigen::Vector3d& ray, const Eigen::Vector3d& centre,
                 double radius);

Camera CameraLookingAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, int width, int height,
                       double focal_px);

// 12 such cameras (320 x 240, focal 400 px) on each of two rings 0.4 m
// from `target`, at `low_deg` and `high_deg` elevation; the high ring is
// turned half a step so that its views fall between the low ring's.
std::vector<Camera> TwoRingsOfCameras(const Eigen::Vector3d& target, double low_deg, double high_deg);

// Depth along the optical axis (CV_32F metres, 0 = none) of an analytic
// scene: `hit` gives the object's nearest ray parameter (<= 0: missed) for
// a unit world ray from the camera centre; a ray that misses it and meets
// the table (z = 0) within the 0.3 m square about the origin sees the
// table, when `table` is set.
cv::Mat RenderAnalyticDepth(const Camera& camera,
                            const std::function<double(const Eigen::Vector3d& origin, const Eigen::Vector3d& ray)>& hit,
                            bool table);

// Mean squared error and sum of absolute differences of two CV_32F mattes.
double MatteMse(const cv::Mat& a, const cv::Mat& b);
double MatteSad(const cv::Mat& a, const cv::Mat& b);

}  // namespace relit::reconstruct::testing
