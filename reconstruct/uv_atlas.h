// UV atlas of the proxy mesh, built the way production tools (xatlas,
// UVAtlas) do it, on CGAL: charts grown on the face graph (normal deviation,
// roundness, seam cost), each parameterised with CGAL's LSCM, charts whose
// map flips, overlaps itself or stretches too much split and parameterised
// again, then all charts packed into a square texture with gutter texels
// (bitmap first-fit packing at the largest scale that fits).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/image.h"
#include "core/render/mesh.h"
#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct {

// Per-corner texture coordinates: corner k of triangle f is uv[3 f + k], in
// [0, 1]^2, OBJ convention (u right, v up the texture image).
struct UvAtlas {
  int resolution_px = 0;
  int gutter_px = 0;
  int chart_count = 0;
  std::vector<int> face_chart;          // chart index per triangle
  std::vector<Eigen::Vector2f> corner_uvs;
};

struct AtlasStats {
  int charts = 0;
  int chart_splits = 0;                 // re-splits for flips, overlaps, stretch or topology
  int chart_merges = 0;                 // adjacent charts merged after splitting
  int flipped_triangles = 0;            // UV orientation opposite to the chart's
  int degenerate_triangles = 0;         // zero UV area
  int overlapping_texels = 0;           // texel centres inside two triangles
  int chart_contact_texels = 0;         // texels touched by two charts (conservative)
  int min_chart_gap_texels = 0;         // smallest gap between charts found (capped at gutter + 1)
  double utilisation = 0;               // texels with a centre inside a triangle / resolution^2
  double stretch_l2_mean = 0;           // Sander L2 stretch, area weighted, 1 = isometric up to scale
  double stretch_l2_max = 0;            // per triangle
  double stretch_area_ratio_p95 = 0;    // 95th percentile of max(r, 1/r), r = texel area / mean
  double texels_per_metre = 0;
  nlohmann::json ToJson() const;
};

// Throws relit::Error for an empty mesh or when the charts do not fit.
UvAtlas BuildAtlas(const render::TriangleMesh& mesh, const AtlasOptions& options, AtlasStats* stats);

// Independent validation of an atlas (used by BuildAtlas and the tests):
// rasterises every triangle at the atlas resolution.
AtlasStats MeasureAtlas(const render::TriangleMesh& mesh, const UvAtlas& atlas);

// Chart colours with triangle edges, resolution^2 RGB (for atlas_preview.png).
Image AtlasPreview(const render::TriangleMesh& mesh, const UvAtlas& atlas);

// Writes an OBJ with shared positions (watertight), per-corner UVs (f v/vt/vn)
// and a material library next to it (`<stem>.mtl`).
void WriteObjWithAtlas(const std::string& path, const render::TriangleMesh& mesh,
                       const UvAtlas& atlas);

}  // namespace relit::reconstruct
