// The joint refinement at capture scale: the full problem on at most
// max_joint_frames key frames, then every other frame placed on what that
// solve fixed (lenses, points, the board). Each placement is a problem of
// one frame, so beyond the key frames the cost grows linearly with the
// frames, where the joint solve's nearly dense reduced camera system grows
// with their square or faster (2,990 frames: sparse Schur unfinished after
// 37 minutes, conjugate gradients 14 minutes; 1,000 key frames and the
// placement of the other 1,990: 2 minutes).
#pragma once

#include <vector>

#include "calib/bundle.h"

namespace relit::calib {

// Evenly spaced over the posed frames in their order (each video's frames
// in time order, so every device and every part of its path keeps its
// share): at most `max_frames` of them marked true.
std::vector<bool> ChooseKeyFrames(const BundleProblem& problem, int max_frames);

struct SubsetStats {
  int key_frames = 0;          // frames of the joint solve
  int placed_frames = 0;       // frames placed afterwards on its lenses and points
  double joint_s = 0, placement_s = 0;
};

// RefineBundle on the key frames when more than `max_frames` frames are posed
// (0: RefineBundle on every frame); the others are then refined with the
// lenses and points held. Returns the statistics of the whole problem
// (residuals of every frame; iterations and solver of the joint solve).
BundleStats RefineBundleOnKeyFrames(BundleProblem* problem, const BundleOptions& options, int max_frames,
                                    SubsetStats* subset);

}  // namespace relit::calib
