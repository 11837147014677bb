// Multi-view photometric refinement of the stereo depth maps (dense proxy
// path). SGBM matches one rectified pair at a time, with a fronto-parallel
// window and a quadratic sub-pixel fit: on the dark, flash-lit objects its
// depths scatter by several millimetres. Here every depth pixel is searched
// again, within +/- proxy.photo.search_fraction of its depth, for the
// plane (through the pixel's point, oriented by the depth map's own local
// normal) whose window agrees best with several nearby frames at once
// (zero-mean normalised cross-correlation through the plane-induced
// homography, the best half of the views averaged, so an occluding view does
// not vote). The best hypothesis is refined with a parabola. A pixel whose
// best plane lies at the edge of the search, or agrees with no view, is
// dropped: its stereo depth was an outlier.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "reconstruct/reconstruct_options.h"
#include "reconstruct/stereo_depth.h"

namespace relit::reconstruct {

struct PhotoRefineStats {
  int64_t depth_px = 0;       // pixels with a depth, in the scene box
  int64_t refined_px = 0;     // ... moved to the best plane
  int64_t flat_px = 0;        // ... kept as they were: window without texture
  int64_t dropped_px = 0;     // ... dropped: best plane at the search edge or score too low
  int64_t unseen_px = 0;      // ... kept as they were: no other view holds the window
  double mean_shift_m = 0;    // mean |refined - stereo| depth over the refined pixels
  void Add(const PhotoRefineStats& other);
  nlohmann::json ToJson() const;
};

// The refined depth map of `ref` (CV_32F, metres along the optical axis,
// 0 = none). `others` are the photometric neighbours; only pixels whose
// point lies in `box` are touched (the table is left as it is).
cv::Mat RefineDepthMapPhotometric(const DepthView& ref, const cv::Mat& depth, const std::vector<const DepthView*>& others,
                                  const SceneBox& box, const PhotoRefineOptions& options, PhotoRefineStats* stats);

// All frames (thread-parallel): neighbours from SelectStereoNeighbours with
// the photometric baseline range (options.photo). `on_frame_done` may be empty.
std::vector<cv::Mat> RefineDepthMapsPhotometric(const std::vector<DepthView>& views, const std::vector<cv::Mat>& depths,
                                                const Eigen::Vector3d& centre, const SceneBox& box,
                                                const ProxyOptions& options, PhotoRefineStats* stats,
                                                const std::function<void()>& on_frame_done = {});

}  // namespace relit::reconstruct
