// The Blender Cycles run the renderer benchmarks (relit-bench-pathtracer,
// relit-bench-cues) put beside relit's: its command-line options, and the
// CyclesOptions for a render with relit's own settings. Header-only: the
// paths come from the benchmarks' RELIT_BENCH_* definitions.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include <CLI/CLI.hpp>

#include "bench/cycles.h"

namespace relit::bench {

struct CyclesComparison {
  bool enabled = true;
  std::string blender = "blender";
  std::string assets_dir = RELIT_BENCH_ASSETS_DIR;
  std::string script = RELIT_BENCH_SOURCE_DIR "/cycles_scene.py";

  void AddOptions(CLI::App& app) {
    app.add_flag("!--no-cycles", enabled, "skip the Blender Cycles comparison");
    app.add_option("--blender", blender, "Blender executable");
    app.add_option("--assets", assets_dir, "directory holding spot.obj");
    app.add_option("--cycles-script", script, "path of bench/cycles_scene.py");
  }

  // Cycles rendering what relit rendered: same threads, repeats, samples per
  // pixel, bounce limit and seed; EXRs and cycles.log in `output_dir`.
  CyclesOptions Render(const std::string& output_dir, int threads, int repeats, int samples_per_pixel,
                       int max_depth, uint64_t seed) const {
    // In CyclesOptions' field order.
    return CyclesOptions{blender, script, std::filesystem::absolute(output_dir).string(), threads, repeats,
                         samples_per_pixel, max_depth, seed};
  }
};

}  // namespace relit::bench
