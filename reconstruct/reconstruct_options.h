// Options of the reconstruct stage (relit-reconstruct): proxy mesh cleanup,
// UV atlas, trimaps and closed-form mattes. Defaults live here; the field
// tables (reconstruct_options.cc) read the YAML file (unknown keys are
// errors), command-line flags go on top, then CheckOptions().
// docs/reconstruct.md's table is generated from the field tables
// (tools/options_doc) and explains every option.
#pragma once

#include <string>

#include "core/option_fields.h"
#include "reconstruct/proxy_normals.h"

namespace relit::reconstruct {

// Multi-view photometric refinement of each depth map (photo_refine.h):
// every depth pixel is searched again within +/- search_fraction of its
// depth (2 x search_steps + 1 planes) for the best mean ZNCC of a (2r+1)^2
// window with the better half of up to `views` frames within
// max_baseline_deg; pixels with a window contrast below min_texture grey
// levels (of 255) keep their stereo depth, pixels whose best plane is at the
// search edge or scores below min_score are dropped. color_sigma (grey
// levels, 0 = plain ZNCC) weighs window pixels by their likeness to the
// centre (bilateral). YAML: proxy.photo.
struct PhotoRefineOptions {
  bool enabled = true;
  int views = 4;
  double max_baseline_deg = 30.0;
  int window_radius_px = 3;
  double search_fraction = 0.02;
  int search_steps = 10;
  double min_texture = 2.0;
  double min_score = 0.2;
  double color_sigma = 20.0;
  static const OptionFields<PhotoRefineOptions>& Fields();
};

// Depth-map hull (depth_hull.h): a voxel (voxel_m, 0 = the point spacing)
// that min_free_views depth maps see through by more than free_tolerance of
// its depth is carved; the grid is the fused points' bounds widened by
// margin_fraction of their extent (at least 2 cm). Samples of the hull's
// surface farther than point_gap x the point spacing from every fused point
// join Poisson's input. YAML: proxy.hull.
struct DepthHullOptions {
  bool enabled = true;
  double voxel_m = 0;
  int min_free_views = 3;
  double free_tolerance = 0.01;
  double margin_fraction = 0.25;
  double point_gap = 2.0;
  // Below the object: within contact_height_m above proxy.min_height_m, the
  // hull keeps only what lies within contact_radius_m (horizontally) of a
  // fused point that low (0 = keep the whole band). A 10 mm radius keeps
  // feet whose dark sides the stereo misses near the table (demo 1.29 ->
  // 1.27 %, bunny 1.74 -> 1.69 %, `full` 0.93 -> 0.91 %); 20 mm starts to
  // cap the table under a belly (docs/notes/reconstruct-measurements.md).
  double contact_height_m = 0.005;
  double contact_radius_m = 0.010;
  // A hull that reaches more than this share of the grid's sides and top
  // was not carved all around (no depth behind the object): not used. The
  // calib test's geometry pass leaves 21 % open (a roof over the cow); the
  // `full` spheres capture 2.5 %, where the hull is the only surface the
  // mirror sphere gets (rung (d) 13.5 dB without it, 17.1 with it).
  double max_open_border = 0.05;
  static const OptionFields<DepthHullOptions>& Fields();
};

// Where the proxy mesh comes from (docs/reconstruct.md, "Proxy source").
struct ProxyOptions {
  // dense: per-view StereoSGBM depth maps, multi-view consistency, fused
  //   oriented points, screened Poisson (COLMAP poisson_mesher).
  // sparse: CGAL advancing-front surface over COLMAP's sparse points
  //   (W/calib/model/points3D.txt) or, without them, the fused depth points.
  // mesh: the user-supplied `mesh` (set by --mesh).
  std::string method = "dense";
  int max_frames = 0;                   // frames used for depth (0 = all; else evenly spaced)
  // Stereo neighbours of each reference frame: up to `neighbours`, with a
  // triangulation angle at the crop centre in [min, max] degrees, closest
  // to target_baseline_deg, preferring one on each side.
  int neighbours = 2;
  double min_baseline_deg = 4.0;
  double target_baseline_deg = 10.0;
  double max_baseline_deg = 25.0;
  // OpenCV StereoSGBM on the rectified pair (P1/P2 = 8/32 x channels x block²).
  int block_size_px = 5;
  int uniqueness_ratio = 10;
  int speckle_window_px = 50;
  double max_left_right_difference_px = 1.0;  // left-right consistency of the disparities
  // On flash-lit phone V frames (no geometry pass), depth pixels whose
  // reference window (block_size_px wide) has a grey standard deviation
  // below this carry no match, only SGBM's smoothness fill: a chord across a
  // plain or flash-saturated patch, inside a convex surface (the demo cow's
  // top sat 1.7-2.0 mm low there). They are dropped. Demo cue fit at
  // 16 / 24 / 32: 18.04 / 18.42 / 18.45 dB (0: 17.56 with the old carving);
  // at 40 the depth hull fills most of the gaps and the proxy bulges
  // (3.2 mm). The ambient geometry pass keeps every depth: its plain
  // patches match (tiny test 2.12 -> 2.52 mm at 8).
  double flash_min_texture = 24.0;
  // Depth pixels with a farther depth (by more than depth_tolerance x 2)
  // within this many pixels are dropped: SGBM's block spreads a foreground
  // surface's disparity over the background beside it, so rims and feet
  // sat outside the truth. Demo cue fit 0 / 1 / 2: 18.42 / 18.54 / 18.68 dB.
  int edge_margin_px = 2;
  PhotoRefineOptions photo;
  // Multi-view geometric consistency: a depth pixel survives when at least
  // min_consistent_views other frames, and at least min_consistent_fraction
  // of the other frames with a depth where it projects, see the point at
  // the same depth (relative difference below depth_tolerance). The share
  // adapts to how dense the depth maps are: flash-lit frames leave shadows
  // without depth, so 2 views suit them, while an ambient geometry pass
  // has depth nearly everywhere and 2 chance agreements keep stereo noise
  // (demo-size geometry pass 1.14 -> 0.98 %, docs/reconstruct.md).
  int min_consistent_views = 2;
  double min_consistent_fraction = 0.1;
  double depth_tolerance = 0.01;
  double min_height_m = 0.01;           // depth points at or below this height are the board/table
  double min_cluster_fraction = 0.2;    // point clusters smaller than this x the largest are dropped
  double point_spacing_m = 0;           // grid for the fused points (0 = 1.5 x the median pixel footprint)
  int normal_neighbours = 18;           // CGAL jet normal fit
  DepthHullOptions hull;
  // COLMAP poisson_mesher (screened Poisson, Kazhdan & Hoppe 2013): octree
  // depth and density trim (drop surface supported by few points).
  int poisson_depth = 8;
  double poisson_trim = 5.0;
  std::string colmap = "colmap";        // COLMAP executable
  int min_points = 2000;                // fewer fused points: sparse fallback (warning) or error
  bool sparse_fallback = true;
  // Advancing front (sparse): CGAL's radius_ratio_bound and beta (radians).
  double advancing_front_radius_ratio = 5.0;
  double advancing_front_beta = 0.52;
  int threads = 0;                      // 0 = all cores
  static const OptionFields<ProxyOptions>& Fields();
  void Check() const;  // across fields: baselines ordered, odd block, colmap named
};

struct CleanupOptions {
  // Crop: keep faces strictly above the board plane (z > crop_margin_m)
  // and within crop_radius_m (horizontal distance) of the object centre.
  double crop_margin_m = 0.002;
  double crop_radius_m = 0;             // 0 = automatic (see crop_radius_scale)
  // Automatic radius: scale x the spread of the points where the phones'
  // optical axes cross the board region (at least 0.1 m).
  double crop_radius_scale = 1.5;
  // Components with less area than this fraction of the largest are dropped.
  double min_component_fraction = 0.05;
  // Non-manifold vertices/edges of an input mesh are repaired (true) or an
  // error (false).
  bool repair_non_manifold = true;
  int target_faces = 6000;              // after remeshing and decimation
  int remesh_iterations = 3;
  bool fair_holes = true;               // smooth fill of holes (else flat)
  // Topological noise (tiny tunnels of Poisson surfaces on noisy points):
  // after decimation every loop of three edges that is not a triangle is cut
  // and capped; a loop that cuts off at most cut_off_fraction of the faces
  // (a bubble on a neck) removes that part instead (mesh_handles.cc).
  bool cut_small_handles = true;
  double cut_off_fraction = 0.01;
  // Last step: faces that intersect others (folds of the fused surface) are
  // cut out with a few rings of neighbours and the holes refilled, for up to
  // self_intersection_rounds rounds (RemoveSelfIntersections).
  bool remove_self_intersections = true;
  int self_intersection_rounds = 10;
  static const OptionFields<CleanupOptions>& Fields();
};

struct AtlasOptions {
  int resolution_px = 512;              // square texture the atlas is packed for
  int gutter_px = 4;                    // empty texels kept around every chart
  // Chart growing on the face graph: a face joins a chart while its normal
  // stays within max_normal_deviation_deg of the chart's mean normal; the
  // growth order is by normal deviation + roundness + seam cost.
  double max_normal_deviation_deg = 55.0;
  double roundness_weight = 0.5;
  double seam_weight = 0.5;
  int max_chart_faces = 2000;
  // Charts whose LSCM map flips a triangle, overlaps itself or stretches a
  // triangle beyond max_stretch (Sander's L2 stretch, normalised per chart)
  // are split in two and parameterised again.
  double max_stretch = 2.0;
  // Chart merging after growth (noisy surfaces grow many small charts):
  // adjacent charts, smallest first, longest shared seam first, are merged
  // while the union is a disc whose LSCM map has no flip or overlap and an
  // L2 stretch <= merge_max_stretch.
  bool merge_charts = true;
  double merge_max_stretch = 1.02;
  bool write_preview = true;
  static const OptionFields<AtlasOptions>& Fields();
  void Check() const;  // across fields: gutter well below the resolution
};

// Photometric refinement of the refined proxy (surface_photo_refine.h): each
// vertex searched along its normal for the offset where a patch of the
// surface around it looks alike in the frames that see it. YAML: refine.photometric.
struct SurfacePhotoOptions {
  bool enabled = true;
  int rounds = 3;                 // each round halves the search
  double search_px = 3.0;         // first round: +/- this many pixel footprints along the normal
  int steps = 6;                  // offsets tried on each side of the current surface
  int patch_radius = 4;           // (2r+1)^2 patch samples, one pixel footprint apart
  int max_views = 10;             // views compared: the most frontal, then the widest spread
  double min_facing_cosine = 0.5; // views more grazing than this do not vote
  double min_texture = 3.0;       // patch contrast (grey std) below this: no vote
  double min_score = 0.8;         // best mean ZNCC below this: no vote (lower: more votes, less right)
  double smoothness = 1.0;        // neighbour coupling of the offsets (a sure vertex weighs 1)
  bool light_frames = true;       // phone L's registered frames vote too (light_views.h)
  bool curved_patch = true;       // the patch follows the surface's curvature (a quadric fit to the two-ring)
  static const OptionFields<SurfacePhotoOptions>& Fields();
};

// Silhouette refinement (silhouette_refine.h): the proxy's rim vertices
// moved so that its outline meets the object's outline fitted in each phone V
// frame against the board's print. YAML: refine.silhouette.
struct SilhouetteOptions {
  bool enabled = true;
  int rounds = 3;                 // each round fits the outlines of the moved proxy again
  double search_px = 2.0;         // the outline is searched +/- this many pixels from the proxy's
  double min_contrast = 10.0;     // object against board at the outline, in the fit's residual RMS
  double lit_cosine = 0.5;        // a rim lit at least this well votes where the object is brighter
  double shadow_cosine = 0.2;     // a rim lit less than this votes where the object is darker
  double rim_cosine = 0.4;        // vertices whose normal is this close to across the view form the rim
  int min_votes = 2;              // frames that must vote for a vertex
  double smoothness = 2.0;        // neighbour coupling of the offsets (a vertex with 1 vote weighs 1)
  static const OptionFields<SilhouetteOptions>& Fields();
};

// Refinement of the cleaned proxy against the dense path's depth maps
// (visibility_refine.h); skipped for user meshes and the sparse path.
struct RefineOptions {
  bool enabled = true;
  // Defaults from the calibrated spot captures (docs/reconstruct.md): the
  // `full` proxy's Chamfer 4.24 -> 3.25 mm, demo 7.02 -> 6.62 mm.
  int iterations = 20;
  double step_m = 0;                    // first (largest) move per iteration (0 = 2 x the median pixel footprint)
  // A view sees through a vertex when its depth there exceeds the vertex's
  // by more than this fraction (the 3x3 nearest depth, so edges do not carve).
  // Consistent depths still stray 4-10 mm behind the surface: at 0.01 a
  // quarter of the demo truth's top vertices counted as carved, and the
  // proxy's top sank ~1 mm. 0.1 leaves carving to Poisson's large bulges.
  double free_space_tolerance = 0.1;
  int min_free_space_views = 3;         // and more views see through it than see it
  double support_band = 0.04;           // depth within this fraction: the view sees the vertex
  double min_facing_cosine = 0.4;       // views at grazing angles or behind the surface do not judge it
  double data_weight = 0.5;             // fraction of the mean offset to the seen surface moved per iteration
  double smoothing = 0.5;               // Taubin lambda per iteration (mu = -1.02 lambda); 0 = none
  // Taubin passes (lambda = smoothing) after the last iteration, with no
  // data term: depth noise leaves the surface lumpy (demo: normals 21 deg
  // from the truth's, median), and the cues shade every lump.
  int final_smoothing_iterations = 20;
  SurfacePhotoOptions photometric;      // then the photometric search (needs the frames)
  SilhouetteOptions silhouette;         // then the outlines (needs the flash positions)
  static const OptionFields<RefineOptions>& Fields();
};

struct TrimapOptions {
  // Half width of the unknown band on either side of the projected proxy
  // silhouette: fixed pixels (0 = automatic), else
  //   band_min_px + image_fraction x image diagonal + projected proxy_error_m.
  int band_px = 0;
  int band_min_px = 2;
  double image_fraction = 0.004;
  // Expected proxy error (metres). The band must reach the proxy's far
  // errors, not its mean: the demo's proxy is 2.4 mm off the true surface
  // on average but 6 mm at the 90th percentile (docs/notes/benchmarks-history.md); on its
  // frames 8-12 px bands give the same mattes, 4-6 px bands worse ones.
  double proxy_error_m = 0.008;
  static const OptionFields<TrimapOptions>& Fields();
};

struct MattingOptions {
  int window_radius_px = 1;             // Levin et al.: 3x3 windows
  double epsilon = 1e-7;                // colour-line regulariser (Levin et al.'s value)
  // Pull towards the proxy silhouette where colour says little (it also
  // keeps regions without known pixels solvable); 1e-5 suited proxies 5-7
  // mm off, 1e-2 the hull's (docs/reconstruct.md).
  double prior_weight = 1e-2;
  // Frames above this size are solved coarse-to-fine: the half-resolution
  // matte fixes the confidently opaque/transparent unknown pixels first.
  double multiscale_min_megapixels = 1.5;
  int threads = 0;                      // 0 = all cores
  static const OptionFields<MattingOptions>& Fields();
};

struct ReconstructOptions {
  std::string workspace;                // W: reads W/calib, writes W/reconstruct
  std::string mesh;                     // user-supplied mesh (OBJ/PLY, world frame); needs proxy.method: mesh
  std::string log_level = "info";
  // --force: replace an output folder that relit did not write (never one
  // holding an input, never a file). Not an option of the config file.
  bool force = false;
  int max_matte_frames = 0;             // 0 = every phone V frame
  ProxyOptions proxy;
  CleanupOptions cleanup;
  RefineOptions refine;
  AtlasOptions atlas;
  TrimapOptions trimap;
  MattingOptions matting;
  NormalMapOptions normal_map;
  static const OptionFields<ReconstructOptions>& Fields();
  void Check() const;  // across fields: the workspace, mesh and proxy.method agree
};

}  // namespace relit::reconstruct
