// relit-bench-pathtracer: throughput of relit's path tracer on a fixed scene
// (Spot the cow on a ground quad, one point light), side by side with
//   (a) bare Embree traversal of exactly the same rays, and
//   (b) Blender Cycles (CPU) rendering the same scene, spp and resolution,
// for a Lambert and a GGX cow. A benchmark, not a test: it prints numbers
// and only fails when something cannot run. Results: docs/benchmarks.md.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include "bench/bench_scene.h"
#include "bench/bench_util.h"
#include "bench/cycles.h"
#include "bench/cycles_comparison.h"
#include "bench/raw_embree.h"
#include "core/error.h"
#include "core/main_wrapper.h"
#include "core/run_record.h"

namespace relit::bench {
namespace {

struct Options {
  int width = 320;
  int height = 240;
  int spp = 16;
  int max_depth = 8;
  int repeats = 3;
  int threads = 0;  // 0 = all hardware threads
  uint64_t seed = 0;
  CyclesComparison cycles;
  std::string output_dir = "bench-out";
};

struct SceneResult {
  CowMaterial material = CowMaterial::kLambert;
  double build_seconds = 0;   // scene construction + Embree BVH build
  double render_seconds = 0;  // best RenderImage wall time
  double render_cpu_seconds = 0;  // best RenderImage process CPU time (all threads)
  uint64_t samples = 0;
  RayCounts counts;
  float observed_max_diff = 0;  // observed vs timed render; 0 = the same workload
  RawTraceResult embree_instanced, embree_flat;
  Image radiance, object_ids;
  ImageComparison noise_cow;  // relit seed s vs s+1 on the cow: the noise floor
};

SceneResult RunRelit(const Options& o, const BenchSceneSpec& spec, const render::TriangleMesh& cow,
                     CowMaterial material) {
  SceneResult r;
  r.material = material;
  const auto build_start = std::chrono::steady_clock::now();
  render::Scene scene;
  BuildRelitScene(spec, cow, material, &scene);
  r.build_seconds = SecondsSince(build_start);

  const Camera camera = spec.MakeCamera();
  render::RenderOptions options;
  options.samples_per_pixel = o.spp;
  options.max_depth = o.max_depth;
  options.seed = o.seed;
  render::RenderResult rendered;
  r.render_seconds = r.render_cpu_seconds = -1;
  for (int i = 0; i < std::max(1, o.repeats); ++i) {
    const double cpu_start = ProcessCpuSeconds();
    const auto start = std::chrono::steady_clock::now();
    rendered = render::RenderImage(scene, camera, options);
    const double seconds = SecondsSince(start), cpu_seconds = ProcessCpuSeconds() - cpu_start;
    if (r.render_seconds < 0 || seconds < r.render_seconds) r.render_seconds = seconds;
    if (r.render_cpu_seconds < 0 || cpu_seconds < r.render_cpu_seconds) r.render_cpu_seconds = cpu_seconds;
  }
  r.samples = static_cast<uint64_t>(o.width) * o.height * o.spp;
  r.radiance = rendered.radiance;
  r.object_ids = rendered.object_id;

  // Same seed, same rays: the observed run traces exactly the timed workload.
  ObservedRender observed = RenderObserved(scene, camera, options, /*record_rays=*/true);
  r.counts = observed.counts;
  r.observed_max_diff = MaxAbsDifference(observed.radiance, rendered.radiance);
  r.embree_instanced = RawEmbreeScene(scene, RawEmbreeScene::Layout::kInstanced).Trace(observed.rays, o.repeats);
  r.embree_flat = RawEmbreeScene(scene, RawEmbreeScene::Layout::kFlat).Trace(observed.rays, o.repeats);

  options.seed = o.seed + 1;
  const render::RenderResult other = render::RenderImage(scene, camera, options);
  r.noise_cow = CompareOnObject(rendered.radiance, other.radiance, rendered.object_id, kCowObjectId);
  WriteImage(o.output_dir + "/relit_" + MaterialName(material) + ".exr", rendered.radiance, PixelStorage::kFloat);
  return r;
}

double Mrays(double rays, double seconds) { return seconds > 0 ? rays / seconds * 1e-6 : 0; }

void PrintThroughput(const std::vector<SceneResult>& results) {
  std::printf("\nThroughput: rays = every Intersect/Occluded call of RenderImage (camera, bounce, shadow, AOV);\n"
              "best of repeats; "
              "wall = wall clock, cpu = process CPU time of all threads\n");
  std::printf("%-8s %6s %8s %8s %7s %9s %13s %13s %10s %10s %10s\n", "scene", "Mrays", "rays/spl", "relit s",
              "cpu s", "Msample/s", "relit Mray/s", "Embree Mray/s", "relit/E", "relit/E", "flat Mray/s");
  std::printf("%-8s %6s %8s %8s %7s %9s %13s %13s %10s %10s %10s\n", "", "", "", "wall", "", "wall", "wall",
              "inst, wall", "wall", "cpu", "wall");
  for (const SceneResult& r : results) {
    const double rays = static_cast<double>(r.counts.Total());
    const double relit = Mrays(rays, r.render_seconds);
    const double inst = r.embree_instanced.RaysPerSecond() * 1e-6;
    const double flat = r.embree_flat.RaysPerSecond() * 1e-6;
    std::printf("%-8s %6.3f %8.2f %8.3f %7.3f %9.3f %13.3f %13.3f %10.3f %10.3f %10.3f\n",
                MaterialName(r.material), rays * 1e-6, rays / static_cast<double>(r.samples), r.render_seconds,
                r.render_cpu_seconds, Mrays(static_cast<double>(r.samples), r.render_seconds), relit, inst,
                inst > 0 ? relit / inst : 0,
                r.render_cpu_seconds > 0 ? r.embree_instanced.cpu_seconds / r.render_cpu_seconds : 0, flat);
  }
  for (const SceneResult& r : results) {
    std::printf("rays %-7s intersect %llu, occluded %llu; observed vs timed render max |diff| %g%s\n",
                MaterialName(r.material), static_cast<unsigned long long>(r.counts.intersected),
                static_cast<unsigned long long>(r.counts.occluded), r.observed_max_diff,
                r.observed_max_diff == 0 ? " (same workload)" : " (WORKLOAD DIFFERS: counts approximate)");
  }
  std::printf("Embree = bare rtcIntersect1/rtcOccluded1 on the same rays, relit's two-level instanced BVH;\n"
              "flat = the same with one world-space BVH.\n");
}

void PrintCycles(const std::vector<SceneResult>& results, const CyclesResult& cycles, const Options& o) {
  std::printf("\nCycles: %s\n", cycles.status.c_str());
  if (!cycles.ran) return;
  std::printf("%-8s %8s %8s %8s %9s %8s %9s %9s %8s %8s %8s %8s\n", "scene", "relit s", "build s", "Cycles s",
              "relit/Cyc", "relit", "Cycles", "relit/Cyc", "cow", "cow", "cow", "ground");
  std::printf("%-8s %8s %8s %8s %9s %8s %9s %9s %8s %8s %8s %8s\n", "", "wall", "wall", "wall", "wall", "cpu s",
              "cpu s", "cpu", "reldiff", "ratio", "noise", "ratio");
  for (const SceneResult& r : results) {
    const CyclesRender* c = cycles.Find(MaterialName(r.material));
    if (c == nullptr) continue;
    const Image image = ReadImage(c->exr_path);
    const ImageComparison cow = CompareOnObject(r.radiance, image, r.object_ids, kCowObjectId);
    const ImageComparison ground = CompareOnObject(r.radiance, image, r.object_ids, kGroundObjectId);
    const double relit = r.build_seconds + r.render_seconds;
    const double relit_cpu = r.build_seconds + r.render_cpu_seconds;  // build: wall time, ~1% of the total
    std::printf("%-8s %8.3f %8.3f %8.3f %9.3f %8.3f %9.3f %9.3f %8.3f %8.3f %8.3f %8.3f\n", MaterialName(r.material),
                r.render_seconds, r.build_seconds, c->seconds, c->seconds > 0 ? relit / c->seconds : 0, relit_cpu,
                c->cpu_seconds, c->cpu_seconds > 0 ? relit_cpu / c->cpu_seconds : 0, cow.mean_relative_difference,
                cow.mean_ratio, r.noise_cow.mean_relative_difference, ground.mean_ratio);
  }
  std::printf("relit/Cyc = relit (scene build + RenderImage) / Cycles render operator (sync + BVH + render +\n"
              "EXR write). cow reldiff = mean over interior cow pixels of 2|relit-Cycles|/(relit+Cycles)\n"
              "(luminance); ratio = mean relit / mean Cycles; noise = reldiff of relit against itself with\n"
              "seed %llu (the per-pixel noise floor at this spp). Images: %s/{relit,cycles}_*.exr\n",
              static_cast<unsigned long long>(o.seed + 1), o.output_dir.c_str());
}

int Run(int argc, char** argv) {
  Options o;
  CLI::App app{"relit path tracer benchmark: relit vs raw Embree vs Blender Cycles"};
  app.add_option("--width", o.width, "image width, pixels")->check(CLI::Range(8, 8192));
  app.add_option("--height", o.height, "image height, pixels")->check(CLI::Range(8, 8192));
  app.add_option("--spp", o.spp, "samples per pixel")->check(CLI::Range(1, 65536));
  app.add_option("--max-depth", o.max_depth, "relit max_depth (Cycles max_bounces = max-depth - 1)")
      ->check(CLI::Range(1, 64));
  app.add_option("--repeats", o.repeats, "timing repeats; the best is reported")->check(CLI::Range(1, 100));
  app.add_option("--threads", o.threads, "threads for relit, Embree and Cycles (0 = all cores)")
      ->check(CLI::Range(0, 1024));
  app.add_option("--seed", o.seed, "relit render seed (Cycles uses the same number)");
  o.cycles.AddOptions(app);
  app.add_option("--output-dir", o.output_dir, "where rendered EXRs and cycles.log are written");
  CLI11_PARSE(app, argc, argv);
  if (o.threads <= 0) o.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(o.threads));
  std::filesystem::create_directories(o.output_dir);

  BenchSceneSpec spec;
  spec.mesh_path = o.cycles.assets_dir + "/spot.obj";
  spec.width = o.width;
  spec.height = o.height;
  const render::TriangleMesh cow = LoadBenchMesh(&spec);
  std::printf("relit path tracer benchmark, %s, load average %s\n", Today().c_str(), LoadAverage().c_str());
  std::printf("scene: %s (%zu triangles) + ground quad, 1 point light, %dx%d, %d spp, max depth %d, %d threads\n",
              spec.mesh_path.c_str(), cow.triangles.size(), o.width, o.height, o.spp, o.max_depth, o.threads);
  std::fflush(stdout);

  const std::vector<CowMaterial> materials = {CowMaterial::kLambert, CowMaterial::kGgx};
  std::vector<SceneResult> results;
  for (CowMaterial material : materials) {
    std::printf("rendering %s with relit ...\n", MaterialName(material));
    std::fflush(stdout);
    results.push_back(RunRelit(o, spec, cow, material));
  }
  PrintThroughput(results);

  CyclesResult cycles;
  cycles.status = "skipped (--no-cycles)";
  if (o.cycles.enabled) {
    const CyclesOptions c = o.cycles.Render(o.output_dir, o.threads, o.repeats, o.spp, o.max_depth, o.seed);
    std::printf("\nrendering with Blender Cycles ...\n%s\n", CyclesCommand(spec, c, materials).c_str());
    std::fflush(stdout);
    cycles = RunCycles(spec, c, materials);
  }
  PrintCycles(results, cycles, o);
  std::printf("load average at the end: %s\n", LoadAverage().c_str());
  return 0;
}

}  // namespace
}  // namespace relit::bench

int main(int argc, char** argv) { return relit::RunMain(argc, argv, relit::bench::Run); }
