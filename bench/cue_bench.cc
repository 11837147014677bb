// relit-bench-cues: seconds per frame of relit's radiance-cue rendering
// (relight::RenderCueFrame: the 5 DNL basis materials, Lambert + GGX alpha
// 0.02/0.05/0.13/0.34, with global illumination, all traced along shared
// paths in one pass) side by side with Blender Cycles (CPU) rendering the
// same 5 cues as 5 separate renders: same mesh, camera, point light,
// resolution, samples per pixel and bounce limit. Also the peak resident
// memory of one cue frame and, as a sanity check, each cue's mean radiance
// relit vs Cycles. A benchmark, not a test. Results: docs/benchmarks.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include "bench/bench_scene.h"
#include "bench/bench_util.h"
#include "bench/cycles.h"
#include "bench/cycles_comparison.h"
#include "core/error.h"
#include "core/main_wrapper.h"
#include "core/render/cue_renderer.h"
#include "core/run_record.h"
#include "relight/cue_frames.h"

namespace relit::bench {
namespace {

struct Options {
  std::vector<std::string> sizes = {"320x240", "480x360"};
  int spp = 16;       // relight cues.samples_per_pixel default
  int max_depth = 4;  // relight cues.max_depth default
  int repeats = 3;
  int threads = 2;
  uint64_t seed = 1;
  CyclesComparison cycles;
  std::string output_dir = "bench-out/cues";
};

// One cue basis as a cycles_scene.py material token: Diffuse BSDF for the
// Lambert cue, Glossy BSDF (GGX, roughness sqrt(alpha)) for the GGX cues.
std::string BasisToken(int index, const render::CueBasis& basis) {
  const std::string name = "cue" + std::to_string(index) + "_" + basis.name;
  const render::BsdfParams& b = basis.bsdf;
  const bool diffuse = (b.specular == 0).all();
  RELIT_CHECK(diffuse != (b.diffuse == 0).all());  // Cycles gets one BSDF per cue
  if (diffuse) return DiffuseToken(name, b.diffuse[0]);
  // The Glossy BSDF has no Fresnel term: relit's cue bases use F0 = 1.
  RELIT_CHECK((b.f0 == 1).all());
  return GlossyToken(name, b.specular[0], b.alpha);
}

struct SizeResult {
  int width = 0, height = 0;
  double build_seconds = 0;          // Scene::Commit of the cow (once per stage in relit)
  double render_seconds = -1;        // best RenderCueFrame wall time
  double render_cpu_seconds = -1;    // best process CPU time of the same
  double write_seconds = -1;         // best WriteImage (half EXR, as the cue stage)
  double rss_before_mib = 0, peak_mib = 0;  // around the first RenderCueFrame
  Image frame, other_seed;           // for the comparison
  CyclesResult cycles;
};

SizeResult RunSize(const Options& o, BenchSceneSpec spec, const render::TriangleMesh& cow) {
  SizeResult r;
  r.width = spec.width;
  r.height = spec.height;
  const std::string out_dir = o.output_dir + "/" + std::to_string(spec.width) + "x" + std::to_string(spec.height);
  std::filesystem::create_directories(out_dir);

  // The cue scene is the object alone (the cue stage renders the proxy
  // alone); RenderCueFrame ignores its material and counts object id 1 in A.
  const auto build_start = std::chrono::steady_clock::now();
  render::Scene scene;
  const int mesh = scene.AddMesh(cow);
  scene.AddInstance(mesh, scene.AddMaterial(render::Material::Lambert(Rgb::Constant(0.5f))),
                    spec.cow_world_from_object, 1);
  scene.Commit();
  r.build_seconds = SecondsSince(build_start);

  const Camera camera = spec.MakeCamera();
  const relight::CueLight light =
      relight::CueLight::Point(spec.light_position.cast<double>(), spec.light_intensity);
  relight::CueRenderSettings settings;
  settings.samples_per_pixel = o.spp;
  settings.max_depth = o.max_depth;
  settings.seed = o.seed;
  const std::string exr = out_dir + "/relit_cues.exr";
  for (int i = 0; i < o.repeats; ++i) {
    // The first render also gives the frame's peak memory (VmHWM reset just before).
    if (i == 0) {
      r.rss_before_mib = ProcStatusMiB("VmRSS");
      if (!ResetPeakRss()) r.rss_before_mib = -1;
    }
    const double cpu_start = ProcessCpuSeconds();
    const auto start = std::chrono::steady_clock::now();
    r.frame = relight::RenderCueFrame(scene, camera, light, settings);
    const double seconds = SecondsSince(start), cpu_seconds = ProcessCpuSeconds() - cpu_start;
    if (i == 0) r.peak_mib = ProcStatusMiB("VmHWM");
    if (r.render_seconds < 0 || seconds < r.render_seconds) r.render_seconds = seconds;
    if (r.render_cpu_seconds < 0 || cpu_seconds < r.render_cpu_seconds) r.render_cpu_seconds = cpu_seconds;
    const auto write_start = std::chrono::steady_clock::now();
    WriteImage(exr, r.frame);  // half floats, as relit-relight cues writes them
    const double write_seconds = SecondsSince(write_start);
    if (r.write_seconds < 0 || write_seconds < r.write_seconds) r.write_seconds = write_seconds;
  }
  settings.seed = o.seed + 1;
  r.other_seed = relight::RenderCueFrame(scene, camera, light, settings);

  if (o.cycles.enabled) {
    const CyclesOptions c = o.cycles.Render(out_dir, o.threads, o.repeats, o.spp, o.max_depth, o.seed);
    std::vector<std::string> tokens;
    const std::vector<render::CueBasis> basis = render::DefaultCueBasis();
    for (size_t k = 0; k < basis.size(); ++k) tokens.push_back(BasisToken(static_cast<int>(k), basis[k]));
    std::printf("rendering the 5 cues with Blender Cycles ...\n%s\n", CyclesCommand(spec, c, tokens).c_str());
    std::fflush(stdout);
    r.cycles = RunCycles(spec, c, tokens);
  } else {
    r.cycles.status = "skipped (--no-cycles)";
  }
  return r;
}

Image CueRgb(const Image& frame, int k) {
  const std::string p = "cue" + std::to_string(k) + ".";
  return frame.SelectChannels({p + "R", p + "G", p + "B"});
}

void PrintTimes(const Options& o, const std::vector<SizeResult>& results) {
  std::printf("\n| resolution | spp | max depth | relit s/frame (5 cues, 1 pass) | relit + EXR write s | "
              "Cycles s/frame (5 renders) | relit/Cycles (wall) | relit CPU s | Cycles CPU s | relit/Cycles (CPU) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  for (const SizeResult& r : results) {
    double cycles = 0, cycles_cpu = 0;
    for (const CyclesRender& c : r.cycles.renders) {
      cycles += c.seconds;
      cycles_cpu += c.cpu_seconds;
    }
    const double relit = r.render_seconds + r.write_seconds;
    if (r.cycles.ran) {
      std::printf("| %dx%d | %d | %d | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f |\n", r.width, r.height, o.spp,
                  o.max_depth, r.render_seconds, relit, cycles, relit / cycles, r.render_cpu_seconds, cycles_cpu,
                  r.render_cpu_seconds / cycles_cpu);
    } else {
      std::printf("| %dx%d | %d | %d | %.3f | %.3f | - | - | %.3f | - | - |\n", r.width, r.height, o.spp, o.max_depth,
                  r.render_seconds, relit, r.render_cpu_seconds);
    }
  }
  std::printf("relit: best of %d RenderCueFrame calls (scene already built, as in the cue stage; build %.4f s),\n"
              "plus writing the half-float cue EXR. Cycles: sum over the 5 cues of the best bpy.ops.render.render\n"
              "time (sync + BVH + render + EXR write; Blender start-up and scene set-up excluded).\n",
              o.repeats, results.empty() ? 0.0 : results[0].build_seconds);
  for (const SizeResult& r : results) {
    std::printf("Cycles %dx%d: %s;", r.width, r.height, r.cycles.status.c_str());
    for (const CyclesRender& c : r.cycles.renders) std::printf(" %s %.3f s", c.material.c_str(), c.seconds);
    std::printf("\n");
  }

  std::printf("\nPeak resident memory of one cue frame (VmHWM reset before the first RenderCueFrame):\n");
  std::printf("| resolution | RSS before MiB | peak RSS MiB | peak - before MiB |\n|---|---|---|---|\n");
  for (const SizeResult& r : results) {
    std::printf("| %dx%d | %.1f | %.1f | %.1f |\n", r.width, r.height, r.rss_before_mib, r.peak_mib,
                r.peak_mib - r.rss_before_mib);
  }
}

void PrintQuality(const std::vector<SizeResult>& results) {
  const std::vector<render::CueBasis> basis = render::DefaultCueBasis();
  std::printf("\nSanity check: each cue relit vs Cycles over interior object pixels (A = 1 in the whole 3x3\n"
              "neighbourhood); ratio = mean luminance relit / Cycles, reldiff = mean 2|a-b|/(a+b) per pixel,\n"
              "noise = reldiff of relit against relit with the next seed (the Monte Carlo floor).\n");
  std::printf("| resolution | cue | relit GGX alpha | Cycles roughness | pixels | mean ratio | reldiff | noise |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (const SizeResult& r : results) {
    if (!r.cycles.ran) continue;
    const Image coverage = r.frame.SelectChannels({"A"});
    for (size_t k = 0; k < basis.size(); ++k) {
      const std::string name = "cue" + std::to_string(k) + "_" + basis[k].name;
      const CyclesRender* c = r.cycles.Find(name);
      if (c == nullptr) continue;
      const Image cycles = ReadImage(c->exr_path);
      const Image relit = CueRgb(r.frame, static_cast<int>(k));
      const ImageComparison cmp = CompareOnObject(relit, cycles, coverage, 1);
      const ImageComparison noise = CompareOnObject(relit, CueRgb(r.other_seed, static_cast<int>(k)), coverage, 1);
      const bool diffuse = (basis[k].bsdf.specular == 0).all();
      std::printf("| %dx%d | %s | %s | %s | %d | %.3f | %.3f | %.3f |\n", r.width, r.height, basis[k].name.c_str(),
                  diffuse ? "-" : std::to_string(basis[k].bsdf.alpha).substr(0, 4).c_str(),
                  diffuse ? "- (Diffuse BSDF)" : std::to_string(std::sqrt(basis[k].bsdf.alpha)).substr(0, 6).c_str(),
                  cmp.pixels, cmp.mean_ratio, cmp.mean_relative_difference, noise.mean_relative_difference);
    }
  }
}

int Run(int argc, char** argv) {
  Options o;
  CLI::App app{"relit radiance-cue rendering vs Blender Cycles rendering the same 5 cues"};
  app.add_option("--size", o.sizes, "WIDTHxHEIGHT, repeatable (default 320x240 480x360)");
  app.add_option("--spp", o.spp, "samples per pixel (relit: shared by the 5 cues)")->check(CLI::Range(1, 65536));
  app.add_option("--max-depth", o.max_depth, "relit max_depth (Cycles max_bounces = max-depth - 1)")
      ->check(CLI::Range(1, 64));
  app.add_option("--repeats", o.repeats, "timing repeats; the best is reported")->check(CLI::Range(1, 100));
  app.add_option("--threads", o.threads, "threads for relit and Cycles")->check(CLI::Range(1, 1024));
  app.add_option("--seed", o.seed, "relit seed (Cycles uses the same number)");
  o.cycles.AddOptions(app);
  app.add_option("--output-dir", o.output_dir, "where EXRs and cycles.log are written (one folder per size)");
  CLI11_PARSE(app, argc, argv);
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(o.threads));

  BenchSceneSpec spec;
  spec.mesh_path = o.cycles.assets_dir + "/spot.obj";
  spec.ground_half_size = 0;  // cue scene: the object alone
  const render::TriangleMesh cow = LoadBenchMesh(&spec);
  std::printf("relit cue benchmark, %s, load average %s\n", Today().c_str(), LoadAverage().c_str());
  std::printf("scene: %s (%zu triangles) alone, 1 point light (%g W/sr), %d spp, max depth %d, %d threads\n",
              spec.mesh_path.c_str(), cow.triangles.size(), spec.light_intensity, o.spp, o.max_depth, o.threads);
  std::fflush(stdout);

  std::vector<SizeResult> results;
  for (const std::string& size : o.sizes) {
    BenchSceneSpec sized = spec;
    RELIT_REQUIRE(std::sscanf(size.c_str(), "%dx%d", &sized.width, &sized.height) == 2 && sized.width >= 8 &&
                      sized.height >= 8,
                  "--size expects WIDTHxHEIGHT (e.g. 320x240), got '", size, "'");
    std::printf("\n%s: rendering the cues with relit ...\n", size.c_str());
    std::fflush(stdout);
    results.push_back(RunSize(o, sized, cow));
  }
  PrintTimes(o, results);
  PrintQuality(results);
  std::printf("load average at the end: %s\n", LoadAverage().c_str());
  return 0;
}

}  // namespace
}  // namespace relit::bench

int main(int argc, char** argv) { return relit::RunMain(argc, argv, relit::bench::Run); }
