// Intrinsics and poses from board observations alone: OpenCV's
// calibrateCameraCharuco for a first lens estimate per device and a planar
// PnP pose (IPPE + Levenberg-Marquardt) per frame, in the world frame of
// core/board.h.
#pragma once

#include <string>
#include <vector>

#include "calib/board_detect.h"
#include "core/board.h"
#include "core/camera.h"

namespace relit::calib {

struct BoardCalibration {
  Intrinsics intrinsics;
  double rms_px = 0;
  int frames_used = 0;
  double view_angle_span_deg = 0;  // largest angle between two board normals seen
  int corners_used = 0;
  int corners_rejected = 0;        // dropped as outliers before the final solve
};

// calibrateCameraCharuco on the observations with at least `min_corners`
// corners (at most `max_frames` of them, spread evenly), then again without
// the corners reprojecting further than max(1 px, 4 robust sigmas): under
// strong perspective interpolateCornersCharuco places a few corners several
// pixels off, which a least-squares lens fit cannot absorb (5 % focal error
// on a tiny board clip). `device` names the phone in errors. Throws relit::Error for too few usable frames or
// degenerate motion (all board views within a few degrees of each other).
BoardCalibration CalibrateFromBoard(const std::vector<const BoardObservation*>& observations,
                                    const BoardSpec& spec, int width, int height, bool refine_k3, bool square_pixels,
                                    bool refine_tangential,
                                    int min_corners, int max_frames, const std::string& device);

// cam_from_world of one frame from its ChArUco corners (world positions by
// CharucoCornersWorld). False with fewer than `min_corners` corners or when
// PnP fails. *rms_px receives the reprojection RMS.
bool BoardPose(const BoardObservation& observation, const Intrinsics& intrinsics,
               const BoardSpec& spec, int min_corners, Rigid3* cam_from_world, double* rms_px);

}  // namespace relit::calib
