// A synthetic joint-refinement problem with a known answer, shared by the
// bundle tests.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "core/board.h"
#include "calib/bundle.h"
#include "core/camera.h"

namespace relit::calib {

// 16 frames around the board (varied distance and elevation: the lens is
// observable), their corners and 40 points above the board, with Gaussian
// pixel noise; poses and points start a few millimetres off.
inline BundleProblem BoardAndPoints(double noise_px, std::vector<Rigid3>* poses) {
  BoardSpec spec;
  const Intrinsics truth = Intrinsics::FromFov(640, 480, 1.1);
  BundleProblem base;
  base.corners_world = CharucoCornersWorld(spec);
  base.devices["view"] = truth;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, noise_px);
  std::uniform_real_distribution<double> box(-0.06, 0.06);
  for (int i = 0; i < 16; ++i) {
    const double a = i * 0.3;
    const double r = 0.3 + 0.01 * i;
    poses->push_back(LookAt(Eigen::Vector3d(r * std::cos(a), r * std::sin(a), 0.08 + 0.025 * i),
                            Eigen::Vector3d(0.01 * std::sin(3 * a), 0, 0), Eigen::Vector3d::UnitZ()));
    BundleFrame f;
    f.device = "view";
    f.posed = true;
    const Camera camera(truth, poses->back());
    for (size_t c = 0; c < base.corners_world.size(); ++c) {
      Eigen::Vector2d px;
      if (!camera.Project(base.corners_world[c], &px)) continue;
      f.corner_ids.push_back(static_cast<int>(c));
      f.corners_px.push_back(px + Eigen::Vector2d(noise(rng), noise(rng)));
    }
    f.cam_from_world = Rigid3(poses->back().rotation, poses->back().translation + Eigen::Vector3d(0.003, -0.002, 0.004));
    base.frames.push_back(f);
  }
  for (int k = 0; k < 40; ++k) {
    BundlePoint point;
    const Eigen::Vector3d x(box(rng), box(rng), 0.02 + box(rng) + 0.06);
    for (int i = 0; i < 16; ++i) {
      Eigen::Vector2d px;
      if (Camera(truth, (*poses)[i]).Project(x, &px)) point.observations.push_back({i, px + Eigen::Vector2d(noise(rng), noise(rng))});
    }
    point.position_m = x + Eigen::Vector3d(0.002, 0.001, -0.002);
    base.points.push_back(point);
  }
  return base;
}

}  // namespace relit::calib
