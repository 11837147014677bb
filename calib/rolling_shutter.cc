#include "calib/rolling_shutter.h"

#include <algorithm>
#include <map>

#include <Eigen/Geometry>

namespace relit::calib {

namespace {

Eigen::Vector3d Centre(const Rigid3& cam_from_world) { return cam_from_world.Inverse().translation; }

// Rotation vector of world_from_cam(b) * world_from_cam(a)^-1 (world frame).
Eigen::Vector3d RotationBetween(const Rigid3& a, const Rigid3& b) {
  const Eigen::Quaterniond world_from_a = a.rotation.conjugate();
  const Eigen::Quaterniond world_from_b = b.rotation.conjugate();
  const Eigen::AngleAxisd delta(world_from_b * world_from_a.conjugate());
  return delta.angle() * delta.axis();
}

}  // namespace

std::vector<FrameMotion> EstimateFrameMotion(const std::vector<TimedFrame>& frames, double max_gap_s) {
  std::vector<FrameMotion> motion(frames.size());
  std::map<std::string, std::vector<int>> by_video;
  for (size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].posed && !frames[i].video.empty()) by_video[frames[i].video].push_back(static_cast<int>(i));
  }
  for (auto& [video, order] : by_video) {
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return frames[a].time_s < frames[b].time_s; });
    for (size_t k = 0; k < order.size(); ++k) {
      const TimedFrame& here = frames[order[k]];
      const auto near = [&](size_t j) { return std::abs(frames[order[j]].time_s - here.time_s) <= max_gap_s; };
      const bool has_before = k > 0 && near(k - 1);
      const bool has_after = k + 1 < order.size() && near(k + 1);
      if (!has_before && !has_after) continue;
      const TimedFrame& a = has_before ? frames[order[k - 1]] : here;
      const TimedFrame& b = has_after ? frames[order[k + 1]] : here;
      const double dt = b.time_s - a.time_s;
      if (!(dt > 0)) continue;  // two frames at one time: no motion to read
      FrameMotion& m = motion[order[k]];
      m.known = true;
      m.centre_velocity_m_s = (Centre(b.cam_from_world) - Centre(a.cam_from_world)) / dt;
      m.angular_velocity_rad_s = RotationBetween(a.cam_from_world, b.cam_from_world) / dt;
    }
  }
  return motion;
}

double ReadoutFraction(const Eigen::Vector2d& px, int width, int height, int rotation_deg) {
  const auto fraction = [](double v, int size) { return (v + 0.5) / size - 0.5; };
  switch (rotation_deg) {
    case 90: return -fraction(px.x(), width);   // stored row y = height_stored - 1 - x
    case 180: return -fraction(px.y(), height);
    case 270: return fraction(px.x(), width);   // stored row y = x
    default: return fraction(px.y(), height);
  }
}

}  // namespace relit::calib
