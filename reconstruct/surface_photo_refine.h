// Photometric refinement of the proxy's surface (dense path, after the
// depth-map refinement).
//
// The depth maps come from pixel windows matched between pairs of frames;
// fused, filtered and refined against them the demo's proxy still stands
// about 1.4 mm (a pixel) off the truth, and half a millimetre of proxy
// error already costs the relit images 1.7 dB: every texture edge lands on
// the wrong surface point in each view (docs/notes/relight-fidelity-2026-11-28b.md).
// Here each vertex is searched again along its normal for the offset at
// which a small patch of the surface around it (a quadric fitted to its
// two-ring) looks the same in every frame that sees it (zero-mean normalised cross-correlation of the patch's
// projections into views spread in angle, the better half voting: multi-view mesh
// refinement in the manner of OpenMVS' RefineMesh, with a plane sweep per
// vertex instead of gradients). The frames are flash-lit from positions that
// move, so the score is invariant to each view's gain and offset, and
// textureless patches (white flanks) take no vote. The measured offsets are then smoothed over
// the mesh (weighted by how sure each is) and the vertices moved; a few
// rounds narrow the search.
#pragma once

#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "core/render/mesh.h"
#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct {

struct SurfacePhotoReport {
  int rounds = 0;
  int vertices = 0;
  int measured_vertices_first = 0;  // vertices with a usable photometric optimum, first round
  int measured_vertices_last = 0;   // ... last round
  double search_m = 0;              // first round's search, +/- along the normal
  double patch_spacing_m = 0;       // tangent-plane sample spacing (one pixel footprint)
  double mean_move_m = 0;
  double max_move_m = 0;
  double seconds = 0;
  int self_intersection_faces_replaced = 0;  // by the stage's RemoveSelfIntersections afterwards
  nlohmann::json ToJson() const;
};

// Moves the vertices of a closed, outward-oriented mesh along their normals
// (topology unchanged), never below z = floor_z_m. `grays` are the frames
// (CV_8U) of the undistorted `cameras`, same order and sizes (phone V's
// frames, and phone L's with options.light_frames: light_views.h).
render::TriangleMesh RefineSurfacePhotometric(const render::TriangleMesh& mesh, const std::vector<Camera>& cameras,
                                              const std::vector<cv::Mat>& grays, const SurfacePhotoOptions& options,
                                              double floor_z_m, SurfacePhotoReport* report);

}  // namespace relit::reconstruct
