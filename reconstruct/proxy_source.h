// Where the proxy mesh comes from when the user gives none (issue 6):
// the dense CPU path (StereoSGBM depth maps on rectified neighbour pairs,
// multi-view consistency, fused oriented points, screened Poisson with a
// density trim) and the sparse fallback (CGAL advancing front over COLMAP's
// sparse points or the depth points). The mesh then goes through the same
// cleanup and UV atlas as a user-supplied one.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "core/render/mesh.h"
#include "core/run_record.h"
#include "core/workspace.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/reconstruct_options.h"
#include "reconstruct/visibility_refine.h"

namespace relit::reconstruct {

// The 8-bit frame `image_path` (relative to `workspace`) as CV_8U grey;
// throws relit::Error naming it when its size is not `camera`'s
// (`camera_name` says which camera, for the message).
cv::Mat ReadGrayFrame(const std::filesystem::path& workspace, const std::string& image_path, const Intrinsics& camera,
                      const std::string& camera_name);

// Evenly spaced subset of at most `max_frames` (0 = all).
std::vector<const CalibratedFrame*> Subsample(const std::vector<const CalibratedFrame*>& frames, int max_frames);

// Frames the geometry is taken from: the geometry-pass frames (device
// "geometry", ambient light, as Gao et al. recommend) when cameras.json has
// any with an undistorted image, else the phone V frames. `source` gets the
// device name.
std::vector<const CalibratedFrame*> GeometryFrames(const CamerasFile& cameras, std::string* source);

// The least-squares point where the frames' optical axes converge and a crop
// radius (cleanup.crop_radius_m, or crop_radius_scale x a quarter of the
// median field-of-view width there, at least 0.1 m).
CropRegion CropFromCameras(const CamerasFile& cameras, const std::vector<const CalibratedFrame*>& frames,
                           const CleanupOptions& options);

// Builds the raw proxy (before cleanup) with options.method dense or sparse.
// Intermediate files (fused_points.ply, poisson.ply, the COLMAP log) go to
// `work_dir`. Timings go to `record`, figures to `report`. Throws
// relit::Error when too few points survive, naming the frames that gave none.
// With `evidence`, the depth maps (when the path computed any) are handed on
// for RefineWithDepthMaps.
render::TriangleMesh BuildProxyFromImages(const std::filesystem::path& workspace, const CamerasFile& cameras,
                                          const CropRegion& crop, const ProxyOptions& options,
                                          const std::filesystem::path& work_dir, RunRecord* record,
                                          nlohmann::json* report, DepthEvidence* evidence = nullptr);

}  // namespace relit::reconstruct
