#include "relight/stage_options.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/options.h"

namespace relit::relight {

void CueStageOptions::Read(OptionsReader& r) {
  r.ReadRange("samples_per_pixel", &samples_per_pixel, 1, 1 << 16);
  r.ReadRange("max_depth", &max_depth, 1, 64);
  r.Read("seed", &seed);
  r.Read("flash_intensity", &flash_intensity);
  r.ReadRange("threads", &threads, 0, 1024);
  r.Read("input", &input);
  r.Read("bases", &bases);
  r.Read("support_plane", &support_plane);
  r.ReadRange("paper_albedo", &paper_albedo, 0.0, 1.0);
  r.ReadRange("ink_albedo", &ink_albedo, 0.0, 1.0);
  r.ReadRange("paper_margin_m", &paper_margin_m, 0.0, 1.0);
  r.Read("table_albedo", &table_albedo);
  r.Finish();
  Check();
}

void CueStageOptions::Check() const {
  RELIT_REQUIRE(samples_per_pixel >= 1, "cues.samples_per_pixel must be >= 1, got ", samples_per_pixel);
  RELIT_REQUIRE(max_depth >= 1, "cues.max_depth must be >= 1, got ", max_depth);
  RELIT_REQUIRE(std::isfinite(flash_intensity) && flash_intensity > 0,
                "cues.flash_intensity must be > 0, got ", flash_intensity);
  RELIT_REQUIRE(threads >= 0, "cues.threads must be >= 0 (0 = all cores)");
  Format().Check();
  RELIT_REQUIRE(ink_albedo <= paper_albedo, "cues.ink_albedo (", ink_albedo, ") must not exceed cues.paper_albedo (",
                paper_albedo, ")");
  RELIT_REQUIRE((table_albedo.empty() || table_albedo.size() == 3) &&
                    std::all_of(table_albedo.begin(), table_albedo.end(), [](double a) { return a >= 0 && a <= 1; }),
                "cues.table_albedo must be [] (measured on the frames) or 3 linear RGB values in [0, 1]");
  RELIT_REQUIRE(!support_plane || !Format().is_sh(),
                "cues.support_plane needs cues.input: radiance (set cues.support_plane: false for input: sh)");
}

nlohmann::json CueStageOptions::ToJson() const {
  nlohmann::json j = {{"samples_per_pixel", samples_per_pixel},
                      {"max_depth", max_depth},
                      {"seed", seed},
                      {"flash_intensity", flash_intensity},
                      {"threads", threads}};
  if (!Format().is_default()) j.update(Format().ToJson());
  j["support_plane"] = support_plane;
  if (support_plane) {
    j["paper_albedo"] = paper_albedo;
    j["ink_albedo"] = ink_albedo;
    j["paper_margin_m"] = paper_margin_m;
    j["table_albedo"] = table_albedo;
  }
  return j;
}

void DatasetOptions::Read(OptionsReader& r) {
  r.ReadRange("holdout_every", &holdout_every, 0, 1000000);
  r.Read("drop_unreliable_lights", &drop_unreliable_lights);
  r.ReadRange("max_radiance_quantile", &max_radiance_quantile, 0.5, 1.0);
  r.ReadRange("max_radiance_margin", &max_radiance_margin, 1.0, 100.0);
  r.Finish();
  Check();
}

void DatasetOptions::Check() const {
  RELIT_REQUIRE(holdout_every == 0 || holdout_every >= 2,
                "dataset.holdout_every must be 0 (no validation) or >= 2, got ", holdout_every);
  RELIT_REQUIRE(max_radiance_quantile >= 0.5 && max_radiance_quantile <= 1.0,
                "dataset.max_radiance_quantile must be in [0.5, 1]");
  RELIT_REQUIRE(max_radiance_margin >= 1.0, "dataset.max_radiance_margin must be >= 1");
}

nlohmann::json DatasetOptions::ToJson() const {
  return {{"holdout_every", holdout_every},
          {"drop_unreliable_lights", drop_unreliable_lights},
          {"max_radiance_quantile", max_radiance_quantile},
          {"max_radiance_margin", max_radiance_margin}};
}

void RenderStageOptions::Read(OptionsReader& r) {
  r.ReadRange("frames", &frames, 1, 100000);
  r.ReadRange("width_px", &width_px, 0, 16384);
  r.ReadRange("height_px", &height_px, 0, 16384);
  r.ReadRange("elevation_deg", &elevation_deg, -89.0, 89.0);
  r.ReadRange("distance_scale", &distance_scale, 0.0, 1000.0);
  r.ReadRange("fps", &fps, 0.1, 240.0);
  r.Read("point_light_offset_m", &point_light_offset_m);
  r.Read("point_light_intensity", &point_light_intensity);
  r.Read("environment_map", &environment_map);
  r.Read("environment_scale", &environment_scale);
  r.ReadRange("samples_per_pixel", &samples_per_pixel, 1, 1 << 16);
  r.Read("write_mp4", &write_mp4);
  r.Finish();
  Check();
}

void RenderStageOptions::Check() const {
  RELIT_REQUIRE(frames >= 1, "render.frames must be >= 1");
  RELIT_REQUIRE((width_px == 0) == (height_px == 0),
                "render.width_px and render.height_px must both be 0 (training size) or both be set");
  RELIT_REQUIRE(width_px % 4 == 0 && height_px % 4 == 0,
                "render.width_px and height_px must be multiples of 4 (the networks downsample twice)");
  RELIT_REQUIRE(point_light_offset_m.size() == 3, "render.point_light_offset_m must have 3 numbers (x, y, z)");
  RELIT_REQUIRE(point_light_intensity > 0, "render.point_light_intensity must be > 0");
  RELIT_REQUIRE(environment_scale > 0, "render.environment_scale must be > 0");
  RELIT_REQUIRE(samples_per_pixel >= 1, "render.samples_per_pixel must be >= 1");
}

nlohmann::json RenderStageOptions::ToJson() const {
  return {{"frames", frames},
          {"width_px", width_px},
          {"height_px", height_px},
          {"elevation_deg", elevation_deg},
          {"distance_scale", distance_scale},
          {"fps", fps},
          {"point_light_offset_m", point_light_offset_m},
          {"point_light_intensity", point_light_intensity},
          {"environment_map", environment_map},
          {"environment_scale", environment_scale},
          {"samples_per_pixel", samples_per_pixel},
          {"write_mp4", write_mp4}};
}

}  // namespace relit::relight
