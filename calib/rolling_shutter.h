// Rolling shutter in the joint refinement. A phone's sensor reads its rows
// top to bottom over the readout time; a frame's pose is the one at its
// middle row, and a row read dt later sees the camera moved by its velocity
// times dt. A 1 ms readout on phone L's fast orbit made the lens step's focal
// +0.6 % long on the demo capture (+0.1 % with a global shutter, same
// frames), and phone L and its flash sat 1.5-2 mm too far from the board
// at 1,000 images (docs/notes/calib-at-scale-2026-11-27d.md). Real phones
// read out over 10-30 ms.
//
// Each frame's motion comes from its neighbours in time on the same video
// (finite differences of the refined poses) and is held fixed; the readout
// time of each video is a parameter of the refinement.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/rotation.h>

#include "core/camera.h"

namespace relit::calib {

// A frame's camera motion at its middle row, in the world frame.
struct FrameMotion {
  bool known = false;                                        // false: no neighbour close enough
  Eigen::Vector3d centre_velocity_m_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity_rad_s = Eigen::Vector3d::Zero();  // of world_from_cam
};

// One frame of a video as the motion estimate sees it.
struct TimedFrame {
  std::string video;   // frames of one video share a clock and a readout ("" = a still photo: no motion)
  double time_s = 0;   // the middle row's time
  bool posed = false;
  Rigid3 cam_from_world;
};

// Central differences between the nearest posed frames of the same video
// before and after each frame (one-sided at the ends), each at most
// `max_gap_s` away.
std::vector<FrameMotion> EstimateFrameMotion(const std::vector<TimedFrame>& frames, double max_gap_s);

// The time at which pixel `px` (distorted, written frame of width x height,
// 0 = first pixel's centre) was read, relative to the middle row, as a
// fraction of the readout time: -0.5 at the first sensor row, +0.5 at the
// last. The sensor reads the stored rows top to bottom; the written frame
// is the stored one turned clockwise by rotation_deg (capture's display
// rotation), so at 90 and 270 the readout runs along x.
double ReadoutFraction(const Eigen::Vector2d& px, int width, int height, int rotation_deg);

// A world point moved so that the frame's middle-row pose (q_xyzw, t:
// cam_from_world) sees it where the camera `dt` later saw `point`:
// X' = c + Exp(-w dt) (X - c - v dt), with c the camera centre, v its
// velocity and w its angular velocity (world). Templated for Ceres' Jets:
// the refinement's costs and its error report use this one function.
template <typename T>
void MoveForRow(const T* q_xyzw, const T* t, const T* point, const T& dt, const Eigen::Vector3d& velocity,
                const Eigen::Vector3d& angular_velocity, T* moved) {
  const Eigen::Map<const Eigen::Quaternion<T>> q(q_xyzw);
  const Eigen::Matrix<T, 3, 1> centre = -(q.conjugate() * Eigen::Map<const Eigen::Matrix<T, 3, 1>>(t));
  T offset[3], turned[3];
  const T back[3] = {-angular_velocity.x() * dt, -angular_velocity.y() * dt, -angular_velocity.z() * dt};
  for (int i = 0; i < 3; ++i) offset[i] = point[i] - centre[i] - velocity[i] * dt;
  ceres::AngleAxisRotatePoint(back, offset, turned);
  for (int i = 0; i < 3; ++i) moved[i] = centre[i] + turned[i];
}

}  // namespace relit::calib
