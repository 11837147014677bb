#include "reconstruct/reconstruct_options.h"

#include "core/error.h"
#include "core/log.h"

namespace relit::reconstruct {

RELIT_OPTION_FIELDS(PhotoRefineOptions,
    .Add("enabled", &S::enabled, "refine each stereo depth map photometrically across frames")
    .Add("views", &S::views, 1, 16, "frames compared with each depth map (the better half votes)")
    .Add("max_baseline_deg", &S::max_baseline_deg, 0.5, 90.0, "widest triangulation angle of those frames")
    .Add("window_radius_px", &S::window_radius_px, 1, 10, "ZNCC window radius r: (2r+1)² pixels")
    .Add("search_fraction", &S::search_fraction, 1e-4, 0.5, "depth searched within +/- this fraction")
    .Add("search_steps", &S::search_steps, 1, 100, "planes on each side of the stereo depth")
    .Add("min_texture", &S::min_texture, 0.0, 255.0,
         "window contrast (grey levels) below this: the pixel keeps its stereo depth")
    .Add("min_score", &S::min_score, -1.0, 1.0, "best ZNCC below this: the pixel is dropped")
    .Add("color_sigma", &S::color_sigma, 0.0, 1000.0,
         "bilateral weight of window pixels by likeness to the centre, grey levels (0 = plain ZNCC)"))

RELIT_OPTION_FIELDS(DepthHullOptions,
    .Add("enabled", &S::enabled, "add samples of the depth-map hull (space carving) to Poisson's input")
    .Add("voxel_m", &S::voxel_m, 0.0, 1.0, "voxel side, metres (0 = the point spacing)")
    .Add("min_free_views", &S::min_free_views, 1, 1000, "depth maps that must see through a voxel to carve it")
    .Add("free_tolerance", &S::free_tolerance, 0.0, 1.0,
         "seeing through: beyond the voxel by this fraction of its depth")
    .Add("margin_fraction", &S::margin_fraction, 0.0, 10.0,
         "grid: the fused points' bounds widened by this fraction of their extent (at least 2 cm)")
    .Add("point_gap", &S::point_gap, 0.0, 100.0,
         "hull samples farther than this x the point spacing from every fused point are added")
    .Add("contact_height_m", &S::contact_height_m, 0.0, 1.0,
         "band above proxy.min_height_m where the hull keeps only what is near low fused points (0 = keep)")
    .Add("contact_radius_m", &S::contact_radius_m, 0.0, 1.0, "horizontal reach of that rule, metres")
    .Add("max_open_border", &S::max_open_border, 0.0, 1.0,
         "a hull reaching more than this share of the grid's sides and top is not used"))

RELIT_OPTION_FIELDS(ProxyOptions,
    .Add("method", &S::method, {"dense", "sparse", "mesh"},
         "dense stereo + Poisson, sparse COLMAP points + advancing front, or the given mesh (`--proxy-method`)")
    .Add("max_frames", &S::max_frames, 0, 1000000,
         "frames used for depth and phone L frames for refine.photometric, each 0 or >= 3 (0 = all; else evenly spaced)")
    .Add("neighbours", &S::neighbours, 1, 8, "stereo neighbours of each reference frame")
    .Add("min_baseline_deg", &S::min_baseline_deg, 0.1, 90.0, "smallest triangulation angle of a stereo pair")
    .Add("target_baseline_deg", &S::target_baseline_deg, 0.1, 90.0, "preferred angle, between min and max")
    .Add("max_baseline_deg", &S::max_baseline_deg, 0.1, 90.0, "largest angle")
    .Add("block_size_px", &S::block_size_px, 1, 31, "StereoSGBM block, odd (P1/P2 = 8/32 x channels x block²)")
    .Add("uniqueness_ratio", &S::uniqueness_ratio, 0, 100, "StereoSGBM uniqueness ratio, percent")
    .Add("speckle_window_px", &S::speckle_window_px, 0, 10000, "StereoSGBM speckle filter window")
    .Add("max_left_right_difference_px", &S::max_left_right_difference_px, 0.0, 100.0,
         "left-right consistency of the disparities")
    .Add("flash_min_texture", &S::flash_min_texture, 0.0, 255.0,
         "phone V (flash-lit) frames: grey std (0-255) of a depth pixel's block below which SGBM only filled it "
         "in: dropped (0 = keep all; the geometry pass keeps all)")
    .Add("edge_margin_px", &S::edge_margin_px, 0, 20,
         "depth pixels this close to a farther depth (2 x depth_tolerance) are dropped: SGBM's fattened rims")
    .Section("photo", &S::photo)
    .Add("min_consistent_views", &S::min_consistent_views, 0, 100,
         "other frames that must see a depth pixel's point at the same depth")
    .Add("min_consistent_fraction", &S::min_consistent_fraction, 0.0, 1.0,
         "... and this share of the other frames with a depth there")
    .Add("depth_tolerance", &S::depth_tolerance, 1e-5, 1.0, "same depth: relative difference below this")
    .Add("min_height_m", &S::min_height_m, 0.0, 1.0, "depth points at or below this height are the board/table")
    .Add("min_cluster_fraction", &S::min_cluster_fraction, 0.0, 1.0,
         "point clusters smaller than this x the largest are dropped (board edges, table)")
    .Add("point_spacing_m", &S::point_spacing_m, 0.0, 1.0,
         "grid of the fused points (0 = 1.5 x the median pixel footprint)")
    .Add("normal_neighbours", &S::normal_neighbours, 4, 200, "CGAL jet normal fit neighbours")
    .Section("hull", &S::hull)
    .Add("poisson_depth", &S::poisson_depth, 5, 14, "screened Poisson octree depth")
    .Add("poisson_trim", &S::poisson_trim, 0.0, 20.0, "Poisson density trim (drops surface few points support)")
    .Add("colmap", &S::colmap, "the COLMAP executable (poisson_mesher)")
    .Add("min_points", &S::min_points, 10, 100000000, "fewer fused points: sparse fallback (warning) or error")
    .Add("sparse_fallback", &S::sparse_fallback, "fall back to the sparse path when dense finds too few points")
    .Add("advancing_front_radius_ratio", &S::advancing_front_radius_ratio, 1.0, 1000.0,
         "CGAL advancing front radius_ratio_bound (sparse)")
    .Add("advancing_front_beta", &S::advancing_front_beta, 0.01, 3.14, "CGAL advancing front beta, radians")
    .Add("threads", &S::threads, 0, 1024,
         "0 = all cores (Poisson runs on one thread unless set: COLMAP's OpenMP threads spin on a loaded machine)")
    .Moved("photo_refine", "photo.enabled")
    .Moved("photo_views", "photo.views")
    .Moved("photo_max_baseline_deg", "photo.max_baseline_deg")
    .Moved("photo_window_radius_px", "photo.window_radius_px")
    .Moved("photo_search_fraction", "photo.search_fraction")
    .Moved("photo_search_steps", "photo.search_steps")
    .Moved("photo_min_texture", "photo.min_texture")
    .Moved("photo_min_score", "photo.min_score")
    .Moved("photo_color_sigma", "photo.color_sigma")
    .Moved("hull_points", "hull.enabled")
    .Moved("hull_voxel_m", "hull.voxel_m")
    .Moved("hull_min_free_views", "hull.min_free_views")
    .Moved("hull_free_tolerance", "hull.free_tolerance")
    .Moved("hull_margin_fraction", "hull.margin_fraction")
    .Moved("hull_point_gap", "hull.point_gap")
    .Moved("hull_contact_height_m", "hull.contact_height_m")
    .Moved("hull_contact_radius_m", "hull.contact_radius_m")
    .Moved("hull_max_open_border", "hull.max_open_border"))

void ProxyOptions::Check() const {
  RELIT_REQUIRE(max_frames == 0 || max_frames >= 3, "max_frames must be 0 (all) or >= 3, got ", max_frames);
  RELIT_REQUIRE(min_baseline_deg <= target_baseline_deg && target_baseline_deg <= max_baseline_deg,
                "need min_baseline_deg <= target_baseline_deg <= max_baseline_deg, got ", min_baseline_deg, ", ",
                target_baseline_deg, ", ", max_baseline_deg);
  RELIT_REQUIRE(block_size_px % 2 == 1, "block_size_px must be odd, got ", block_size_px);
  RELIT_REQUIRE(!colmap.empty(), "colmap (the COLMAP executable) must not be empty");
}

RELIT_OPTION_FIELDS(CleanupOptions,
    .Add("crop_margin_m", &S::crop_margin_m, 0.0, 1.0, "keep faces above the board plane by this much")
    .Add("crop_radius_m", &S::crop_radius_m, 0.0, 100.0,
         "... and within this horizontal distance of the object centre (0 = automatic)")
    .Add("crop_radius_scale", &S::crop_radius_scale, 0.1, 100.0,
         "automatic radius: this x the spread of where the phones' optical axes meet the board (>= 0.1 m)")
    .Add("min_component_fraction", &S::min_component_fraction, 0.0, 1.0,
         "components with less area than this x the largest are dropped")
    .Add("repair_non_manifold", &S::repair_non_manifold,
         "repair non-manifold vertices/edges of an input mesh (false: an error)")
    .Add("target_faces", &S::target_faces, 100, 10000000, "faces after remeshing and decimation")
    .Add("remesh_iterations", &S::remesh_iterations, 0, 100, "isotropic remeshing iterations")
    .Add("fair_holes", &S::fair_holes, "smooth fill of holes (else flat)")
    .Add("cut_small_handles", &S::cut_small_handles,
         "cut and cap loops of three edges that are not triangles (tiny tunnels)")
    .Add("cut_off_fraction", &S::cut_off_fraction, 0.0, 0.5,
         "a loop cutting off at most this share of the faces removes that part instead")
    .Add("remove_self_intersections", &S::remove_self_intersections,
         "cut out self-intersecting faces with a few rings and refill the holes")
    .Add("self_intersection_rounds", &S::self_intersection_rounds, 1, 100, "rounds of that"))

RELIT_OPTION_FIELDS(AtlasOptions,
    .Add("resolution_px", &S::resolution_px, 16, 16384, "square texture the atlas is packed for")
    .Add("gutter_px", &S::gutter_px, 1, 64, "empty texels around every chart; below resolution / 8")
    .Add("max_normal_deviation_deg", &S::max_normal_deviation_deg, 1.0, 89.0,
         "a face joins a chart while its normal stays this close to the chart's mean")
    .Add("roundness_weight", &S::roundness_weight, 0.0, 100.0, "chart growth order: roundness weight")
    .Add("seam_weight", &S::seam_weight, 0.0, 100.0, "chart growth order: seam cost weight")
    .Add("max_chart_faces", &S::max_chart_faces, 1, 10000000, "faces per chart at most")
    .Add("max_stretch", &S::max_stretch, 1.0, 1000.0,
         "charts whose LSCM map stretches beyond this (L2, per chart) are split")
    .Add("merge_charts", &S::merge_charts, "merge adjacent charts while the union maps well")
    .Add("merge_max_stretch", &S::merge_max_stretch, 1.0, 1000.0, "largest L2 stretch of a merged chart")
    .Add("write_preview", &S::write_preview, "write the atlas preview image"))

void AtlasOptions::Check() const {
  RELIT_REQUIRE(gutter_px * 8 < resolution_px, "gutter_px must be well below the resolution (< resolution_px / 8), got ",
                gutter_px);
}

RELIT_OPTION_FIELDS(SurfacePhotoOptions,
    .Add("enabled", &S::enabled, "search each refined vertex along its normal for the most photo-consistent offset")
    .Add("rounds", &S::rounds, 0, 20, "search rounds, each over half the previous range")
    .Add("search_px", &S::search_px, 0.1, 100.0, "first round's range, +/- pixel footprints along the normal")
    .Add("steps", &S::steps, 1, 100, "offsets tried on each side")
    .Add("patch_radius", &S::patch_radius, 1, 10, "patch of (2r+1)^2 samples, a footprint apart")
    .Add("max_views", &S::max_views, 2, 100, "frames compared per vertex: the most frontal, then each the farthest in angle from those picked")
    .Add("min_facing_cosine", &S::min_facing_cosine, 0.0, 1.0, "more grazing frames do not vote")
    .Add("min_texture", &S::min_texture, 0.0, 255.0, "patch grey std below this: the vertex takes no vote")
    .Add("min_score", &S::min_score, -1.0, 1.0, "best mean ZNCC below this: the vertex takes no vote")
    .Add("smoothness", &S::smoothness, 0.0, 1e6, "neighbour coupling of the offsets (a sure vertex weighs 1)")
    .Add("curved_patch", &S::curved_patch,
         "the patch follows the surface (a quadric fit to the vertex's two-ring), not its tangent plane")
    .Add("light_frames", &S::light_frames,
         "phone L's registered frames (flash-lit from their own lens, other viewpoints) vote beside phone V's"))

RELIT_OPTION_FIELDS(SilhouetteOptions,
    .Add("enabled", &S::enabled,
         "move the proxy's rim so that its outline meets the object's outline fitted against the board's print")
    .Add("rounds", &S::rounds, 0, 20, "rounds, each fitting the moved proxy's outlines again")
    .Add("search_px", &S::search_px, 0.25, 20.0, "outline searched +/- this many pixels from the proxy's")
    .Add("min_contrast", &S::min_contrast, 0.0, 1e6,
         "object against board at the outline, in the fit's residual RMS; less: no vote")
    .Add("lit_cosine", &S::lit_cosine, -1.0, 1.0,
         "a rim the flash lights at least this well votes where the object is brighter than the board")
    .Add("shadow_cosine", &S::shadow_cosine, -1.0, 1.0,
         "a rim lit less than this votes where the object is darker than the board")
    .Add("rim_cosine", &S::rim_cosine, 0.01, 1.0,
         "vertices whose normal is within this cosine of across the view form the rim")
    .Add("min_votes", &S::min_votes, 1, 1000, "frames that must vote for a vertex")
    .Add("smoothness", &S::smoothness, 0.0, 1e6, "neighbour coupling of the offsets (one vote weighs 1)"))

RELIT_OPTION_FIELDS(RefineOptions,
    .Add("enabled", &S::enabled, "refine the cleaned proxy against the dense path's depth maps")
    .Add("iterations", &S::iterations, 0, 10000, "refinement iterations")
    .Add("step_m", &S::step_m, 0.0, 1.0, "first (largest) move per iteration (0 = 2 x the median pixel footprint)")
    .Add("free_space_tolerance", &S::free_space_tolerance, 1e-5, 1.0,
         "a view sees through a vertex when its depth exceeds the vertex's by this fraction")
    .Add("min_free_space_views", &S::min_free_space_views, 1, 1000, "... and more views than this see through it")
    .Add("support_band", &S::support_band, 1e-5, 1.0, "depth within this fraction: the view sees the vertex")
    .Add("min_facing_cosine", &S::min_facing_cosine, 0.0, 1.0, "views at grazing angles or behind do not judge")
    .Add("data_weight", &S::data_weight, 0.0, 1.0, "share of the offset to the seen surface moved per iteration")
    .Add("smoothing", &S::smoothing, 0.0, 1.0, "Taubin lambda per iteration (mu = -1.02 lambda; 0 = none)")
    .Add("final_smoothing_iterations", &S::final_smoothing_iterations, 0, 10000,
         "Taubin passes (lambda = smoothing) after the last iteration, no data term")
    .Section("photometric", &S::photometric)
    .Section("silhouette", &S::silhouette))

RELIT_OPTION_FIELDS(TrimapOptions,
    .Add("band_px", &S::band_px, 0, 1000, "unknown band half width, pixels (0 = automatic, below)")
    .Add("band_min_px", &S::band_min_px, 1, 1000, "automatic: this many pixels ...")
    .Add("image_fraction", &S::image_fraction, 0.0, 0.5, "... + this x the image diagonal ...")
    .Add("proxy_error_m", &S::proxy_error_m, 0.0, 1.0, "... + this proxy error (metres) projected"))

RELIT_OPTION_FIELDS(MattingOptions,
    .Add("window_radius_px", &S::window_radius_px, 1, 5, "closed-form matting window radius (1: 3x3)")
    .Add("epsilon", &S::epsilon, 1e-12, 1.0, "colour-line regulariser")
    .Add("prior_weight", &S::prior_weight, 0.0, 1.0, "pull towards the proxy silhouette where colour says little")
    .Add("multiscale_min_megapixels", &S::multiscale_min_megapixels, 0.0, 1000.0,
         "larger frames are solved coarse to fine")
    .Add("threads", &S::threads, 0, 1024, "0 = all cores"))

RELIT_OPTION_FIELDS(ReconstructOptions,
    .Add("workspace", &S::workspace, "W: reads W/calib, writes W/reconstruct (`--workspace`)")
    .Add("mesh", &S::mesh,
         "user mesh (OBJ/PLY, board frame, metres; `--mesh`; pipeline: inputs.proxy_mesh); alone, it sets "
         "proxy.method: mesh")
    .Add("log_level", &S::log_level, LogLevelNames(), "what the stage prints (`--log-level`)")
    .Add("max_matte_frames", &S::max_matte_frames, 0, 1000000, "phone V frames matted (0 = all)")
    .Section("proxy", &S::proxy)
    .Section("cleanup", &S::cleanup)
    .Section("refine", &S::refine)
    .Section("atlas", &S::atlas)
    .Section("trimap", &S::trimap)
    .Section("matting", &S::matting)
    .Section("normal_map", &S::normal_map)
    .OnRead([](OptionsReader& r, S* s) {
      // mesh: alone means "use it"
      if (!s->mesh.empty() && !r.Child("proxy").Has("method")) s->proxy.method = "mesh";
    }))

void ReconstructOptions::Check() const {
  RELIT_REQUIRE(!workspace.empty(), "reconstruct: the workspace is required (--workspace W)");
  RELIT_REQUIRE(proxy.method != "mesh" || !mesh.empty(),
                "reconstruct: proxy.method is mesh but no mesh is given (--mesh FILE or mesh: in the YAML)");
  RELIT_REQUIRE(mesh.empty() || proxy.method == "mesh", "reconstruct: a mesh (", mesh,
                ") is given but proxy.method is ", proxy.method, "; set proxy.method: mesh (--mesh does)");
}

}  // namespace relit::reconstruct
