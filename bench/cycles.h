// Runs Blender Cycles on the benchmark scene (bench/cycles_scene.py) from the
// command line and compares its images with relit's.
#pragma once

#include <string>
#include <vector>

#include "bench/bench_scene.h"
#include "core/image.h"

namespace relit::bench {

struct CyclesOptions {
  std::string blender = "blender";  // executable name or path
  std::string script;               // bench/cycles_scene.py
  std::string output_dir;           // EXRs and cycles.log go here
  int threads = 2;
  int repeats = 1;
  int samples_per_pixel = 16;
  int max_depth = 8;                // relit semantics; Cycles gets max_depth - 1
  uint64_t seed = 0;
};

struct CyclesRender {
  std::string material;
  double seconds = 0;      // best wall time of bpy.ops.render.render (sync + BVH + render + EXR write)
  double cpu_seconds = 0;  // best process CPU time (all threads) of the same call
  std::string exr_path;
};

struct CyclesResult {
  bool ran = false;
  std::string status;   // one line for the report: version, or why it did not run
  std::vector<CyclesRender> renders;
  const CyclesRender* Find(const std::string& material) const;
};

// Full path of an executable found on PATH (or the argument itself when it
// contains a '/' and is executable); empty when absent.
std::string FindExecutable(const std::string& name);

// The shell command that renders `materials`; printed for reproducibility.
std::string CyclesCommand(const BenchSceneSpec& spec, const CyclesOptions& options,
                          const std::vector<CowMaterial>& materials);

// Runs Blender; Blender's own output goes to <output_dir>/cycles.log.
// Never throws for a missing or failing Blender: `ran` is false and `status`
// says why.
CyclesResult RunCycles(const BenchSceneSpec& spec, const CyclesOptions& options,
                       const std::vector<CowMaterial>& materials);

// The same with cycles_scene.py material tokens: "lambert", "ggx",
// "NAME=diffuse:ALBEDO" or "NAME=glossy:ALBEDO:ALPHA" (ALPHA = GGX alpha;
// the script sets Cycles' roughness to sqrt(ALPHA)). Renders are named NAME.
std::string CyclesCommand(const BenchSceneSpec& spec, const CyclesOptions& options,
                          const std::vector<std::string>& material_tokens);
CyclesResult RunCycles(const BenchSceneSpec& spec, const CyclesOptions& options,
                       const std::vector<std::string>& material_tokens);
std::string DiffuseToken(const std::string& name, double albedo);
std::string GlossyToken(const std::string& name, double albedo, double ggx_alpha);

struct ImageComparison {
  int pixels = 0;                    // object pixels compared
  double mean_relative_difference = 0;  // mean of 2|a-b|/(a+b) on luminance
  double mean_ratio = 0;             // sum of luminance a / sum of luminance b
};

// Compares two RGB(A) radiance images over the pixels whose pixel-centre
// object id (relit's object_id AOV) is `object_id` in a whole 3x3
// neighbourhood (silhouette pixels, partly covered, are left out).
ImageComparison CompareOnObject(const Image& a, const Image& b, const Image& object_ids, int object_id);

}  // namespace relit::bench
