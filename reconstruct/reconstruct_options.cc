#include "reconstruct/reconstruct_options.h"

#include "core/error.h"

namespace relit::reconstruct {

void ProxyOptions::Read(OptionsReader& r) {
  r.Read("method", &method);
  r.ReadRange("max_frames", &max_frames, 0, 1000000);
  r.ReadRange("neighbours", &neighbours, 1, 8);
  r.ReadRange("min_baseline_deg", &min_baseline_deg, 0.1, 90.0);
  r.ReadRange("target_baseline_deg", &target_baseline_deg, 0.1, 90.0);
  r.ReadRange("max_baseline_deg", &max_baseline_deg, 0.1, 90.0);
  r.ReadRange("block_size_px", &block_size_px, 1, 31);
  r.ReadRange("uniqueness_ratio", &uniqueness_ratio, 0, 100);
  r.ReadRange("speckle_window_px", &speckle_window_px, 0, 10000);
  r.ReadRange("max_left_right_difference_px", &max_left_right_difference_px, 0.0, 100.0);
  r.Read("photo_refine", &photo_refine);
  r.ReadRange("photo_views", &photo_views, 1, 16);
  r.ReadRange("photo_max_baseline_deg", &photo_max_baseline_deg, 0.5, 90.0);
  r.ReadRange("photo_window_radius_px", &photo_window_radius_px, 1, 10);
  r.ReadRange("photo_search_fraction", &photo_search_fraction, 1e-4, 0.5);
  r.ReadRange("photo_search_steps", &photo_search_steps, 1, 100);
  r.ReadRange("photo_min_texture", &photo_min_texture, 0.0, 255.0);
  r.ReadRange("photo_min_score", &photo_min_score, -1.0, 1.0);
  r.ReadRange("photo_color_sigma", &photo_color_sigma, 0.0, 1000.0);
  r.ReadRange("min_consistent_views", &min_consistent_views, 0, 100);
  r.ReadRange("min_consistent_fraction", &min_consistent_fraction, 0.0, 1.0);
  r.ReadRange("depth_tolerance", &depth_tolerance, 1e-5, 1.0);
  r.ReadRange("min_height_m", &min_height_m, 0.0, 1.0);
  r.ReadRange("min_cluster_fraction", &min_cluster_fraction, 0.0, 1.0);
  r.ReadRange("point_spacing_m", &point_spacing_m, 0.0, 1.0);
  r.ReadRange("normal_neighbours", &normal_neighbours, 4, 200);
  r.Read("hull_points", &hull_points);
  r.ReadRange("hull_voxel_m", &hull_voxel_m, 0.0, 1.0);
  r.ReadRange("hull_min_free_views", &hull_min_free_views, 1, 1000);
  r.ReadRange("hull_free_tolerance", &hull_free_tolerance, 0.0, 1.0);
  r.ReadRange("hull_margin_fraction", &hull_margin_fraction, 0.0, 10.0);
  r.ReadRange("hull_point_gap", &hull_point_gap, 0.0, 100.0);
  r.ReadRange("hull_contact_height_m", &hull_contact_height_m, 0.0, 1.0);
  r.ReadRange("hull_contact_radius_m", &hull_contact_radius_m, 0.0, 1.0);
  r.ReadRange("hull_max_open_border", &hull_max_open_border, 0.0, 1.0);
  r.ReadRange("poisson_depth", &poisson_depth, 5, 14);
  r.ReadRange("poisson_trim", &poisson_trim, 0.0, 20.0);
  r.Read("colmap", &colmap);
  r.ReadRange("min_points", &min_points, 10, 100000000);
  r.Read("sparse_fallback", &sparse_fallback);
  r.ReadRange("advancing_front_radius_ratio", &advancing_front_radius_ratio, 1.0, 1000.0);
  r.ReadRange("advancing_front_beta", &advancing_front_beta, 0.01, 3.14);
  r.ReadRange("threads", &threads, 0, 1024);
  r.Finish();
}

void ProxyOptions::Check() const {
  RELIT_REQUIRE(method == "dense" || method == "sparse" || method == "mesh",
                "proxy.method must be dense, sparse or mesh, got '", method, "'");
  RELIT_REQUIRE(max_frames == 0 || max_frames >= 3, "proxy.max_frames must be 0 (all) or >= 3, got ", max_frames);
  RELIT_REQUIRE(neighbours >= 1, "proxy.neighbours must be >= 1");
  RELIT_REQUIRE(min_baseline_deg > 0 && min_baseline_deg <= target_baseline_deg &&
                    target_baseline_deg <= max_baseline_deg,
                "proxy: need 0 < min_baseline_deg <= target_baseline_deg <= max_baseline_deg, got ",
                min_baseline_deg, ", ", target_baseline_deg, ", ", max_baseline_deg);
  RELIT_REQUIRE(block_size_px >= 1 && block_size_px % 2 == 1, "proxy.block_size_px must be odd, got ",
                block_size_px);
  RELIT_REQUIRE(depth_tolerance > 0, "proxy.depth_tolerance must be > 0");
  RELIT_REQUIRE(min_consistent_views >= 0, "proxy.min_consistent_views must be >= 0");
  RELIT_REQUIRE(min_consistent_fraction >= 0 && min_consistent_fraction <= 1,
                "proxy.min_consistent_fraction must be in [0, 1], got ", min_consistent_fraction);
  RELIT_REQUIRE(!colmap.empty(), "proxy.colmap (the COLMAP executable) must not be empty");
  RELIT_REQUIRE(poisson_depth >= 5, "proxy.poisson_depth must be >= 5");
  RELIT_REQUIRE(threads >= 0, "proxy.threads must be >= 0");
}

nlohmann::json ProxyOptions::ToJson() const {
  return {{"method", method},
          {"max_frames", max_frames},
          {"neighbours", neighbours},
          {"min_baseline_deg", min_baseline_deg},
          {"target_baseline_deg", target_baseline_deg},
          {"max_baseline_deg", max_baseline_deg},
          {"block_size_px", block_size_px},
          {"uniqueness_ratio", uniqueness_ratio},
          {"speckle_window_px", speckle_window_px},
          {"max_left_right_difference_px", max_left_right_difference_px},
          {"photo_refine", photo_refine},
          {"photo_views", photo_views},
          {"photo_max_baseline_deg", photo_max_baseline_deg},
          {"photo_window_radius_px", photo_window_radius_px},
          {"photo_search_fraction", photo_search_fraction},
          {"photo_search_steps", photo_search_steps},
          {"photo_min_texture", photo_min_texture},
          {"photo_min_score", photo_min_score},
          {"photo_color_sigma", photo_color_sigma},
          {"min_consistent_views", min_consistent_views},
          {"min_consistent_fraction", min_consistent_fraction},
          {"depth_tolerance", depth_tolerance},
          {"min_height_m", min_height_m},
          {"min_cluster_fraction", min_cluster_fraction},
          {"point_spacing_m", point_spacing_m},
          {"normal_neighbours", normal_neighbours},
          {"hull_points", hull_points},
          {"hull_voxel_m", hull_voxel_m},
          {"hull_min_free_views", hull_min_free_views},
          {"hull_free_tolerance", hull_free_tolerance},
          {"hull_margin_fraction", hull_margin_fraction},
          {"hull_point_gap", hull_point_gap},
          {"hull_contact_height_m", hull_contact_height_m},
          {"hull_contact_radius_m", hull_contact_radius_m},
          {"hull_max_open_border", hull_max_open_border},
          {"poisson_depth", poisson_depth},
          {"poisson_trim", poisson_trim},
          {"colmap", colmap},
          {"min_points", min_points},
          {"sparse_fallback", sparse_fallback},
          {"advancing_front_radius_ratio", advancing_front_radius_ratio},
          {"advancing_front_beta", advancing_front_beta},
          {"threads", threads}};
}

void CleanupOptions::Read(OptionsReader& r) {
  r.ReadRange("crop_margin_m", &crop_margin_m, 0.0, 1.0);
  r.ReadRange("crop_radius_m", &crop_radius_m, 0.0, 100.0);
  r.ReadRange("crop_radius_scale", &crop_radius_scale, 0.1, 100.0);
  r.ReadRange("min_component_fraction", &min_component_fraction, 0.0, 1.0);
  r.Read("repair_non_manifold", &repair_non_manifold);
  r.ReadRange("target_faces", &target_faces, 100, 10000000);
  r.ReadRange("remesh_iterations", &remesh_iterations, 0, 100);
  r.Read("fair_holes", &fair_holes);
  r.Read("cut_small_handles", &cut_small_handles);
  r.ReadRange("cut_off_fraction", &cut_off_fraction, 0.0, 0.5);
  r.Read("remove_self_intersections", &remove_self_intersections);
  r.ReadRange("self_intersection_rounds", &self_intersection_rounds, 1, 100);
  r.Finish();
}

void CleanupOptions::Check() const {
  RELIT_REQUIRE(crop_margin_m >= 0, "cleanup.crop_margin_m must be >= 0, got ", crop_margin_m);
  RELIT_REQUIRE(crop_radius_m >= 0, "cleanup.crop_radius_m must be >= 0 (0 = automatic)");
  RELIT_REQUIRE(crop_radius_scale > 0, "cleanup.crop_radius_scale must be > 0");
  RELIT_REQUIRE(min_component_fraction >= 0 && min_component_fraction <= 1,
                "cleanup.min_component_fraction must be in [0, 1]");
  RELIT_REQUIRE(target_faces >= 100, "cleanup.target_faces must be >= 100, got ", target_faces);
  RELIT_REQUIRE(remesh_iterations >= 0, "cleanup.remesh_iterations must be >= 0");
  RELIT_REQUIRE(cut_off_fraction >= 0 && cut_off_fraction <= 0.5, "cleanup.cut_off_fraction must be in [0, 0.5]");
  RELIT_REQUIRE(self_intersection_rounds >= 1, "cleanup.self_intersection_rounds must be >= 1, got ",
                self_intersection_rounds);
}

nlohmann::json CleanupOptions::ToJson() const {
  return {{"crop_margin_m", crop_margin_m},
          {"crop_radius_m", crop_radius_m},
          {"crop_radius_scale", crop_radius_scale},
          {"min_component_fraction", min_component_fraction},
          {"repair_non_manifold", repair_non_manifold},
          {"target_faces", target_faces},
          {"remesh_iterations", remesh_iterations},
          {"fair_holes", fair_holes},
          {"cut_small_handles", cut_small_handles},
          {"cut_off_fraction", cut_off_fraction},
          {"remove_self_intersections", remove_self_intersections},
          {"self_intersection_rounds", self_intersection_rounds}};
}

void AtlasOptions::Read(OptionsReader& r) {
  r.ReadRange("resolution_px", &resolution_px, 16, 16384);
  r.ReadRange("gutter_px", &gutter_px, 1, 64);
  r.ReadRange("max_normal_deviation_deg", &max_normal_deviation_deg, 1.0, 89.0);
  r.ReadRange("roundness_weight", &roundness_weight, 0.0, 100.0);
  r.ReadRange("seam_weight", &seam_weight, 0.0, 100.0);
  r.ReadRange("max_chart_faces", &max_chart_faces, 1, 10000000);
  r.ReadRange("max_stretch", &max_stretch, 1.0, 1000.0);
  r.Read("merge_charts", &merge_charts);
  r.ReadRange("merge_max_stretch", &merge_max_stretch, 1.0, 1000.0);
  r.Read("write_preview", &write_preview);
  r.Finish();
}

void AtlasOptions::Check() const {
  RELIT_REQUIRE(resolution_px >= 16, "atlas.resolution_px must be >= 16, got ", resolution_px);
  RELIT_REQUIRE(gutter_px >= 1 && gutter_px * 8 < resolution_px,
                "atlas.gutter_px must be >= 1 and well below the resolution, got ", gutter_px);
  RELIT_REQUIRE(max_normal_deviation_deg > 0 && max_normal_deviation_deg < 90,
                "atlas.max_normal_deviation_deg must be in (0, 90)");
  RELIT_REQUIRE(max_chart_faces >= 1, "atlas.max_chart_faces must be >= 1");
  RELIT_REQUIRE(max_stretch >= 1, "atlas.max_stretch must be >= 1");
  RELIT_REQUIRE(merge_max_stretch >= 1, "atlas.merge_max_stretch must be >= 1");
}

nlohmann::json AtlasOptions::ToJson() const {
  return {{"resolution_px", resolution_px},
          {"gutter_px", gutter_px},
          {"max_normal_deviation_deg", max_normal_deviation_deg},
          {"roundness_weight", roundness_weight},
          {"seam_weight", seam_weight},
          {"max_chart_faces", max_chart_faces},
          {"max_stretch", max_stretch},
          {"merge_charts", merge_charts},
          {"merge_max_stretch", merge_max_stretch},
          {"write_preview", write_preview}};
}

void TrimapOptions::Read(OptionsReader& r) {
  r.ReadRange("band_px", &band_px, 0, 1000);
  r.ReadRange("band_min_px", &band_min_px, 1, 1000);
  r.ReadRange("image_fraction", &image_fraction, 0.0, 0.5);
  r.ReadRange("proxy_error_m", &proxy_error_m, 0.0, 1.0);
  r.Finish();
}

void TrimapOptions::Check() const {
  RELIT_REQUIRE(band_px >= 0, "trimap.band_px must be >= 0 (0 = automatic)");
  RELIT_REQUIRE(band_min_px >= 1, "trimap.band_min_px must be >= 1");
  RELIT_REQUIRE(image_fraction >= 0, "trimap.image_fraction must be >= 0");
  RELIT_REQUIRE(proxy_error_m >= 0, "trimap.proxy_error_m must be >= 0");
}

nlohmann::json TrimapOptions::ToJson() const {
  return {{"band_px", band_px},
          {"band_min_px", band_min_px},
          {"image_fraction", image_fraction},
          {"proxy_error_m", proxy_error_m}};
}

void MattingOptions::Read(OptionsReader& r) {
  r.ReadRange("window_radius_px", &window_radius_px, 1, 5);
  r.ReadRange("epsilon", &epsilon, 1e-12, 1.0);
  r.ReadRange("prior_weight", &prior_weight, 0.0, 1.0);
  r.ReadRange("multiscale_min_megapixels", &multiscale_min_megapixels, 0.0, 1000.0);
  r.ReadRange("threads", &threads, 0, 1024);
  r.Finish();
}

void MattingOptions::Check() const {
  RELIT_REQUIRE(window_radius_px >= 1, "matting.window_radius_px must be >= 1");
  RELIT_REQUIRE(epsilon > 0, "matting.epsilon must be > 0");
  RELIT_REQUIRE(prior_weight >= 0, "matting.prior_weight must be >= 0");
  RELIT_REQUIRE(multiscale_min_megapixels >= 0, "matting.multiscale_min_megapixels must be >= 0");
  RELIT_REQUIRE(threads >= 0, "matting.threads must be >= 0");
}

nlohmann::json MattingOptions::ToJson() const {
  return {{"window_radius_px", window_radius_px},
          {"epsilon", epsilon},
          {"prior_weight", prior_weight},
          {"multiscale_min_megapixels", multiscale_min_megapixels},
          {"threads", threads}};
}

void RefineOptions::Read(OptionsReader& r) {
  r.Read("enabled", &enabled);
  r.ReadRange("iterations", &iterations, 0, 10000);
  r.ReadRange("step_m", &step_m, 0.0, 1.0);
  r.ReadRange("free_space_tolerance", &free_space_tolerance, 1e-5, 1.0);
  r.ReadRange("min_free_space_views", &min_free_space_views, 1, 1000);
  r.ReadRange("support_band", &support_band, 1e-5, 1.0);
  r.ReadRange("min_facing_cosine", &min_facing_cosine, 0.0, 1.0);
  r.ReadRange("data_weight", &data_weight, 0.0, 1.0);
  r.ReadRange("smoothing", &smoothing, 0.0, 1.0);
  r.Finish();
}

void RefineOptions::Check() const {
  RELIT_REQUIRE(iterations >= 0, "refine.iterations must be >= 0");
  RELIT_REQUIRE(step_m >= 0, "refine.step_m must be >= 0 (0 = automatic)");
  RELIT_REQUIRE(free_space_tolerance > 0 && support_band > 0, "refine: tolerances must be > 0");
  RELIT_REQUIRE(min_free_space_views >= 1, "refine.min_free_space_views must be >= 1");
  RELIT_REQUIRE(data_weight >= 0 && data_weight <= 1, "refine.data_weight must be in [0, 1]");
  RELIT_REQUIRE(smoothing >= 0 && smoothing <= 1, "refine.smoothing must be in [0, 1]");
}

nlohmann::json RefineOptions::ToJson() const {
  return {{"enabled", enabled},
          {"iterations", iterations},
          {"step_m", step_m},
          {"free_space_tolerance", free_space_tolerance},
          {"min_free_space_views", min_free_space_views},
          {"support_band", support_band},
          {"min_facing_cosine", min_facing_cosine},
          {"data_weight", data_weight},
          {"smoothing", smoothing}};
}

void ReconstructOptions::Read(OptionsReader& r) {
  r.Read("workspace", &workspace);
  r.Read("mesh", &mesh);
  r.Read("log_level", &log_level);
  r.ReadRange("max_matte_frames", &max_matte_frames, 0, 1000000);
  OptionsReader p = r.Child("proxy");
  const bool method_given = p.Has("method");
  proxy.Read(p);
  if (!mesh.empty() && !method_given) proxy.method = "mesh";  // mesh: alone means "use it"
  OptionsReader c = r.Child("cleanup");
  cleanup.Read(c);
  OptionsReader rf = r.Child("refine");
  refine.Read(rf);
  OptionsReader a = r.Child("atlas");
  atlas.Read(a);
  OptionsReader t = r.Child("trimap");
  trimap.Read(t);
  OptionsReader m = r.Child("matting");
  matting.Read(m);
  r.Finish();
}

void ReconstructOptions::Check() const {
  RELIT_REQUIRE(!workspace.empty(), "reconstruct: the workspace is required (--workspace W)");
  RELIT_REQUIRE(max_matte_frames >= 0, "max_matte_frames must be >= 0");
  proxy.Check();
  RELIT_REQUIRE(proxy.method != "mesh" || !mesh.empty(),
                "reconstruct: proxy.method is mesh but no mesh is given (--mesh FILE or mesh: in the YAML)");
  RELIT_REQUIRE(mesh.empty() || proxy.method == "mesh", "reconstruct: a mesh (", mesh,
                ") is given but proxy.method is ", proxy.method, "; set proxy.method: mesh (--mesh does)");
  cleanup.Check();
  refine.Check();
  atlas.Check();
  trimap.Check();
  matting.Check();
}

nlohmann::json ReconstructOptions::ToJson() const {
  return {{"workspace", workspace},
          {"mesh", mesh},
          {"log_level", log_level},
          {"max_matte_frames", max_matte_frames},
          {"proxy", proxy.ToJson()},
          {"cleanup", cleanup.ToJson()},
          {"refine", refine.ToJson()},
          {"atlas", atlas.ToJson()},
          {"trimap", trimap.ToJson()},
          {"matting", matting.ToJson()}};
}

}  // namespace relit::reconstruct
