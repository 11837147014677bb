// Options of the reconstruct stage (relit-reconstruct): proxy mesh cleanup,
// UV atlas, trimaps and closed-form mattes. Defaults live here; a YAML file
// (unknown keys are errors) and command-line flags go on top, then Check().
// docs/reconstruct.md explains every option.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "core/options.h"

namespace relit::reconstruct {

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
  void Read(OptionsReader& reader);
  void Check() const;
  nlohmann::json ToJson() const;
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
  bool write_preview = true;
  void Read(OptionsReader& reader);
  void Check() const;
  nlohmann::json ToJson() const;
};

struct TrimapOptions {
  // Half width of the unknown band on either side of the projected proxy
  // silhouette: fixed pixels (0 = automatic), else
  //   band_min_px + image_fraction x image diagonal + projected proxy_error_m.
  int band_px = 0;
  int band_min_px = 2;
  double image_fraction = 0.004;
  double proxy_error_m = 0.003;
  void Read(OptionsReader& reader);
  void Check() const;
  nlohmann::json ToJson() const;
};

struct MattingOptions {
  int window_radius_px = 1;             // Levin et al.: 3x3 windows
  double epsilon = 1e-7;                // colour-line regulariser (Levin et al.'s value)
  double prior_weight = 1e-5;           // weak pull to the silhouette (keeps regions without known pixels solvable)
  // Frames above this size are solved coarse-to-fine: the half-resolution
  // matte fixes the confidently opaque/transparent unknown pixels first.
  double multiscale_min_megapixels = 1.5;
  int threads = 0;                      // 0 = all cores
  void Read(OptionsReader& reader);
  void Check() const;
  nlohmann::json ToJson() const;
};

struct ReconstructOptions {
  std::string workspace;                // W: reads W/calib, writes W/reconstruct
  std::string mesh;                     // user-supplied mesh (OBJ/PLY, world frame); replaces the dense step
  std::string log_level = "info";
  int max_matte_frames = 0;             // 0 = every phone V frame
  CleanupOptions cleanup;
  AtlasOptions atlas;
  TrimapOptions trimap;
  MattingOptions matting;
  void Read(OptionsReader& reader);
  void Check() const;
  nlohmann::json ToJson() const;
};

}  // namespace relit::reconstruct
