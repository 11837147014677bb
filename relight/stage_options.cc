#include "relight/stage_options.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace relit::relight {

RELIT_OPTION_FIELDS(CueStageOptions,
    .Add("samples_per_pixel", &S::samples_per_pixel, 1, 1 << 16, "paths per pixel, shared by the bases")
    .Add("max_depth", &S::max_depth, 1, 64, "bounces (1 = direct light only)")
    .Add("denoise", &S::denoise,
         "filter the bounce light's path-tracing noise; the flash's direct light stays exact (\"Cue denoising\")")
    .Add("seed", &S::seed, "per-frame seeds derive from it")
    .Add("flash_intensity", &S::flash_intensity,
         "W/sr of the cue light (> 0); fixes the unit of rendered lights")
    .Add("threads", &S::threads, 0, 1024, "0 = all cores")
    .Add("input", &S::input, {CueFormat::kRadiance, CueFormat::kSh},
         "the networks' light input: DNL's radiance cues or the spherical-harmonics DNR baseline (\"Baselines\")")
    .Add("bases", &S::bases, CueFormat::DefaultBasisNames(),
         "basis materials of the radiance cues, in channel order ([lambert] = the 1-basis ablation); "
         "texture channels = bases x model.channels_per_basis")
    .Add("support_plane", &S::support_plane,
         "add the board and the table (z = 0) to every cue scene as context geometry (\"Support plane\"); "
         "must be false with input: sh")
    .Add("paper_albedo", &S::paper_albedo, 0.0, 1.0, "linear albedo of the board's white paper")
    .Add("ink_albedo", &S::ink_albedo, 0.0, 1.0, "linear albedo of its printed black (<= paper_albedo)")
    .Add("paper_margin_m", &S::paper_margin_m, 0.0, 1.0, "white paper around the printed squares, metres")
    .Add("table_albedo", &S::table_albedo,
         "linear RGB albedo of the table beyond the paper; [] = measured on the phone V frames against the paper")
    .Add("board_albedo_map", &S::board_albedo_map,
         "measure the board's albedo map on the phone V frames against the paper (what covers the print under "
         "the object, e.g. a coaster, then shows in the cues); false = the print as printed")
    .Add("board_albedo_texel_m", &S::board_albedo_texel_m, 0.0002, 0.01,
         "texel of the board's albedo map, metres")
    .Add("secondary_material", &S::secondary_material, {"basis", "fitted"},
         "what the proxy wears past the primary hit: basis = each cue's own basis material (DNL); fitted = the "
         "mixture a cue fit of a first rendering of the frames gives, so the cues hold the inter-reflections "
         "between parts of different materials (\"Fitted secondary material\"); fitted needs support_plane "
         "and the default bases")
    .Add("secondary_fit_resolution_px", &S::secondary_fit_resolution_px, 16, 4096,
         "texel grid of secondary_material fitted's cue fit")
    .OnToJson([](const S& s, nlohmann::json* json) {
      if (s.secondary_material == "basis") {  // records of older relit stay equal
        json->erase("secondary_material");
        json->erase("secondary_fit_resolution_px");
      }
      if (s.Format().is_default()) {
        json->erase("input");
        json->erase("bases");
      } else if (s.Format().is_sh()) {
        json->erase("bases");
      }
      if (!s.support_plane) {
        for (const char* key : {"paper_albedo", "ink_albedo", "paper_margin_m", "table_albedo", "board_albedo_map",
                                "board_albedo_texel_m"}) {
          json->erase(key);
        }
      }
    }))

void CueStageOptions::Check() const {
  RELIT_REQUIRE(std::isfinite(flash_intensity) && flash_intensity > 0, "flash_intensity must be > 0, got ",
                flash_intensity);
  Format().Check();
  RELIT_REQUIRE(ink_albedo <= paper_albedo, "ink_albedo (", ink_albedo, ") must not exceed paper_albedo (",
                paper_albedo, ")");
  RELIT_REQUIRE((table_albedo.empty() || table_albedo.size() == 3) &&
                    std::all_of(table_albedo.begin(), table_albedo.end(), [](double a) { return a >= 0 && a <= 1; }),
                "table_albedo must be [] (measured on the frames) or 3 linear RGB values in [0, 1]");
  RELIT_REQUIRE(!support_plane || !Format().is_sh(),
                "support_plane needs input: radiance (set support_plane: false for input: sh)");
  RELIT_REQUIRE(secondary_material == "basis" || (support_plane && Format().is_default()),
                "secondary_material: fitted needs support_plane: true and the default radiance bases (the fit "
                "is of the 5 default cues; the paper gives the flash's scale)");
}

RELIT_OPTION_FIELDS(DatasetOptions,
    .Add("holdout_every", &S::holdout_every, 0, 1000000,
         "every n-th phone V frame (time order) validates and never trains; 0 = none, else >= 2")
    .Add("drop_unreliable_lights", &S::drop_unreliable_lights,
         "drop the frames whose light position calib flagged unreliable")
    .Add("max_radiance_quantile", &S::max_radiance_quantile, 0.5, 1.0,
         "quantile of the training targets' per-pixel maximum taken as M of the log encoding")
    .Add("max_radiance_margin", &S::max_radiance_margin, 1.0, 100.0, "M = that quantile times this"))

void DatasetOptions::Check() const {
  RELIT_REQUIRE(holdout_every == 0 || holdout_every >= 2, "holdout_every must be 0 (no validation) or >= 2, got ",
                holdout_every);
}

RELIT_OPTION_FIELDS(RenderStageOptions,
    .Add("frames", &S::frames, 1, 100000, "turntable frames (one revolution)")
    .Add("width_px", &S::width_px, 0, 16384, "0 = the training images' size; a multiple of 4")
    .Add("height_px", &S::height_px, 0, 16384, "0 = the training images' size; a multiple of 4")
    .Add("elevation_deg", &S::elevation_deg, -89.0, 89.0, "turntable camera elevation above the board")
    .Add("distance_scale", &S::distance_scale, 0.0, 1000.0,
         "camera distance / object radius; 0 = the capture's mean distance")
    .Add("fps", &S::fps, 0.1, 240.0, "MP4 frame rate")
    .Add("point_light_offset_m", &S::point_light_offset_m,
         "the point light relative to the camera, in its frame (x right, y down, z forward), metres")
    .Add("point_light_intensity", &S::point_light_intensity,
         "flash units (1 = the capture's flash as the cues see it); > 0")
    .Add("environment_map", &S::environment_map,
         "EXR/HDR file (equirectangular, +Z up), procedural:sky or procedural:studio; \"\" = procedural:sky")
    .Add("environment_scale", &S::environment_scale, "the map's radiance scale; > 0")
    .Add("samples_per_pixel", &S::samples_per_pixel, 1, 1 << 16, "cue paths per pixel for new views")
    .Add("denoise_cues", &S::denoise_cues,
         "filter the new views' cues with an edge-aware filter guided by the proxy's normals and depth, all "
         "but a point or directional light's exact direct light (\"Cue denoising\"); eval and the turntables")
    .Add("write_mp4", &S::write_mp4, "the turntables as MP4 too"))

void RenderStageOptions::Check() const {
  RELIT_REQUIRE((width_px == 0) == (height_px == 0),
                "width_px and height_px must both be 0 (training size) or both be set");
  RELIT_REQUIRE(width_px % 4 == 0 && height_px % 4 == 0,
                "width_px and height_px must be multiples of 4 (the networks downsample twice)");
  RELIT_REQUIRE(point_light_offset_m.size() == 3, "point_light_offset_m must have 3 numbers (x, y, z)");
  RELIT_REQUIRE(point_light_intensity > 0, "point_light_intensity must be > 0");
  RELIT_REQUIRE(environment_scale > 0, "environment_scale must be > 0");
}

}  // namespace relit::relight
