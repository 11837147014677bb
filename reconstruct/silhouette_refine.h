// Silhouette refinement of the proxy (dense path, after the photometric
// search).
//
// The photometric search (surface_photo_refine.h) needs texture: the cow's
// white flanks take no vote there, and only the depth hull's carving bounds
// them. Yet every phone V frame shows where the object ends: at its outline
// the object meets the board, whose print is known after calib. Along the
// normal of the proxy's projected outline, each frame's profile is fitted
// as "object (a linear ramp) | board print x gain + offset" with the step
// at every sub-pixel offset; the best step is where the object's outline
// lies in that frame, and the proxy vertex on its rim moves along its normal
// to put its outline there.
//
// A rim's own shading biases the step: a rim the flash grazes darkens
// towards its edge (and a dielectric's Fresnel darkens it further), so a
// bright object's step lands inside it. Only two kinds of profile vote: a
// rim the flash lights well that is brighter than the board beside it, and
// a rim in the flash's shadow that is darker than the board. On the demo
// the other kinds sat 0.2-1.6 px inside the truth's outline; these two sit
// within 0.06 px (median). docs/reconstruct.md, step 2d.
#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "core/board.h"
#include "core/camera.h"
#include "core/image.h"
#include "core/render/mesh.h"
#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct {

// One phone V frame: its undistorted camera, the flash position lighting it
// and its linear RGB image (loaded when needed, once per round).
struct SilhouetteView {
  Camera camera;
  Eigen::Vector3d flash_m = Eigen::Vector3d::Zero();
  std::function<Image()> load_image;
};

// The object's outline on one profile across the proxy's outline: samples
// i = 0..n-1 at t_i = (i - (n-1)/2) x step_px along the outward normal, with
// the board print's albedo where each sample's ray meets the board plane.
struct OutlineFit {
  bool found = false;
  double offset_px = 0;  // the object's outline along the profile (0 = centre sample)
  double contrast = 0;   // object against board at the outline, in residual RMS of the fit
  double polarity = 0;   // > 0: the object is brighter than the board there (sum over RGB)
};
OutlineFit FitOutline(const std::vector<Eigen::Vector3f>& colours, const std::vector<float>& board_albedo,
                      double step_px, double search_px);

// The board print's albedo (0 = ink, 1 = paper) at a world point on the
// board plane; 1 (paper) off the print.
class BoardPrint {
 public:
  explicit BoardPrint(const BoardSpec& spec, double texel_m = 0.0005);
  float Albedo(const Eigen::Vector3d& world_point) const;

 private:
  BoardSpec spec_;
  double texel_m_;
  cv::Mat print_;  // CV_32F, rows from the print's top
};

struct SilhouetteReport {
  int rounds = 0;
  int views = 0;
  int vertices = 0;
  int voting_vertices_first = 0;  // vertices with at least min_votes votes, first round
  int voting_vertices_last = 0;
  int64_t votes_first = 0;        // accepted profiles, first round
  int64_t profiles_first = 0;     // profiles fitted, first round
  double mean_move_m = 0;
  double max_move_m = 0;
  double seconds = 0;
  int self_intersection_faces_replaced = 0;  // by the stage's RemoveSelfIntersections afterwards
  nlohmann::json ToJson() const;
};

// Moves the vertices of a closed, outward-oriented mesh along their normals
// (topology unchanged), never below z = floor_z_m.
render::TriangleMesh RefineSilhouettes(const render::TriangleMesh& mesh, const std::vector<SilhouetteView>& views,
                                       const BoardPrint& board, const SilhouetteOptions& options, double floor_z_m,
                                       SilhouetteReport* report);

}  // namespace relit::reconstruct
