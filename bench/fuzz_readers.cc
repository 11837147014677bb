// relit-bench-fuzz: a fuzz pass over relit's readers (docs/refusals.md,
// docs/benchmarks.md "Readers under fuzzing"). Not a test: it runs for
// minutes and its inputs are random.
//
// For each reader a valid seed file is written, then mutated N times (byte
// flips, insertions of hostile tokens such as "nan", "1e400", "*a", tabs,
// deep brackets, deletions, duplications, truncation); every mutant is fed
// to the reader in this process. Each outcome is counted:
//   loaded        the reader accepted it
//   refused       relit::Error (the one-line, user-facing refusal)
//   unclear       another exception (YAML::Exception, nlohmann::json's):
//                 no crash, but the message does not come from relit
//   failed        std::bad_alloc or another std::exception relit should not
//                 let through (counted, printed, saved)
// A crash (signal) or a hang (one input over --hang-s seconds) stops the
// tool after saving the input to --save-dir; exit status 1 when anything
// failed, crashed or hung.
//
//   relit-bench-fuzz [--inputs 2000] [--seed 1] [--only yaml,obj] [--save-dir D]
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <new>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <OpenMesh/Core/System/omstream.hh>
#include <yaml-cpp/exceptions.h>

#include "calib/capture_file.h"
#include "core/error.h"
#include "core/image.h"
#include "core/log.h"
#include "core/render/mesh.h"
#include "core/run_record.h"
#include "core/workspace.h"
#include "pipeline/config.h"
#include "relight/asset.h"
#include "relight/render_stage.h"

namespace fs = std::filesystem;

namespace {

// --- crash and hang reporting (async-signal-safe parts only) ---------------
char g_reader[64] = "";
char g_saved_path[512] = "";
std::atomic<int64_t> g_started_ms{0};
std::atomic<bool> g_running{false};

void WriteAll(int fd, const char* text) {
  size_t left = std::strlen(text);
  while (left > 0) {
    const ssize_t n = ::write(fd, text, left);
    if (n <= 0) return;
    text += n;
    left -= static_cast<size_t>(n);
  }
}

void OnCrash(int signal_number) {
  WriteAll(2, "\nrelit-bench-fuzz: CRASH (signal ");
  char number[8];
  std::snprintf(number, sizeof(number), "%d", signal_number);
  WriteAll(2, number);
  WriteAll(2, ") in reader ");
  WriteAll(2, g_reader);
  WriteAll(2, "; input saved as ");
  WriteAll(2, g_saved_path);
  WriteAll(2, "\n");
  ::_exit(2);
}

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// --- mutation ---------------------------------------------------------------
const std::vector<std::string>& Tokens() {
  static const std::vector<std::string> tokens = {
      "nan", "NaN", "inf", "-inf", "1e400", "-1e400", "1e-400", "-1", "0", "-0", "2147483648",
      "99999999999999999999", "100000", "\t", "\n", " ", ":", "- ", "&a ", "*a", "&b [*a, *a, *a]", "[",
      "]", "{", "}", "[[[[[[[[[[[[[[[[", "{\"a\": ", "\"", "'", "\\", ",", "null", "true", "[]", "{}",
      "\xff\xfe", std::string("\0", 1), "v ", "f 1 2 99999", "f -5 1 2", "vt ", "vn ", "#",
      "element vertex 4294967295\n", "property list uchar int vertex_indices\n", "end_header\n"};
  return tokens;
}

std::string Mutate(const std::string& seed, std::mt19937_64& rng) {
  std::string s = seed;
  std::uniform_int_distribution<int> count_dist(1, 4);
  const int count = count_dist(rng);
  for (int m = 0; m < count; ++m) {
    const size_t size = s.size();
    std::uniform_int_distribution<size_t> pos_dist(0, size);
    const size_t pos = pos_dist(rng);
    switch (std::uniform_int_distribution<int>(0, 6)(rng)) {
      case 0:  // flip a byte
        if (size > 0) s[std::min(pos, size - 1)] ^= static_cast<char>(1 << (rng() % 8));
        break;
      case 1:  // random byte
        s.insert(pos, 1, static_cast<char>(rng() % 256));
        break;
      case 2:  // hostile token
        s.insert(pos, Tokens()[rng() % Tokens().size()]);
        break;
      case 3: {  // delete a range
        const size_t len = std::min<size_t>(size - std::min(pos, size), 1 + rng() % 16);
        s.erase(std::min(pos, size), len);
        break;
      }
      case 4: {  // duplicate a range (repetition: aliases, deep nesting)
        const size_t len = std::min<size_t>(size - std::min(pos, size), 1 + rng() % 32);
        const std::string piece = s.substr(std::min(pos, size), len);
        for (int k = static_cast<int>(rng() % 8); k >= 0; --k) s.insert(pos, piece);
        break;
      }
      case 5:  // truncate
        s.resize(pos);
        break;
      default: {  // replace a number-looking character run with a token
        const size_t at = s.find_first_of("0123456789", pos);
        if (at != std::string::npos) {
          const size_t end = s.find_first_not_of("0123456789.e-", at);
          s.replace(at, (end == std::string::npos ? s.size() : end) - at, Tokens()[rng() % 12]);
        }
        break;
      }
    }
  }
  return s;
}

void WriteText(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// --- readers and their seeds --------------------------------------------------
struct Reader {
  std::string name;
  std::string file;  // where the mutant is written (relative to the work dir)
  std::function<std::string(const fs::path& dir)> seed;
  std::function<void(const fs::path& dir, const fs::path& file)> read;
};

// A seed that relit's own writer makes: `write(path)` to <dir>/<name>, and
// the text it wrote.
std::function<std::string(const fs::path&)> WrittenSeed(const std::string& name,
                                                        std::function<void(const std::string& path)> write) {
  return [name, write](const fs::path& dir) {
    write((dir / name).string());
    return ReadText(dir / name);
  };
}

// A seed given as text.
std::function<std::string(const fs::path&)> TextSeed(std::string text) {
  return [text](const fs::path&) { return text; };
}

// Reads a mutant with `read(path)` (what it returns is not needed).
std::function<void(const fs::path&, const fs::path&)> ReadWith(std::function<void(const std::string& path)> read) {
  return [read](const fs::path&, const fs::path& file) { read(file.string()); };
}

relit::CamerasFile SeedCameras() {
  relit::CamerasFile f;
  relit::Intrinsics k;
  k.width = 64;
  k.height = 48;
  k.fx = k.fy = 60;
  k.cx = 31.5;
  k.cy = 23.5;
  f.devices["view"] = k;
  f.devices["light"] = k;
  f.undistorted_view = k;
  for (int i = 0; i < 2; ++i) {
    relit::CalibratedFrame frame;
    frame.name = "view/00000" + std::to_string(i);
    frame.device = "view";
    frame.time_s = 0.1 * i;
    frame.image_linear = "calib/view_linear/" + std::to_string(i) + ".exr";
    frame.image_8bit = "calib/view/" + std::to_string(i) + ".png";
    f.frames.push_back(frame);
  }
  return f;
}

std::vector<Reader> Readers() {
  std::vector<Reader> readers;
  readers.push_back({"yaml", "pipeline.yaml",
                     TextSeed("inputs: {view: capture/view.mp4, light: capture/light.mp4}\n"
                              "board: {squares_x: 7, squares_y: 5, square_length_m: 0.03, marker_length_m: 0.022}\n"
                              "capture:\n  view_select: {target_frames: 50}\n"
                              "calib:\n  detect: {min_corners: 8}\n"
                              "reconstruct:\n  atlas: {resolution_px: 256}\n"
                              "relight:\n  cues: &c {samples_per_pixel: 4}\n  train: {steps: 10}\n"
                              "  partitions: {layout: single}\n"
                              "run: {jobs: 1, executor: local}\n"),
                     ReadWith([](const std::string& path) { relit::pipeline::PipelineConfig::Load(path); })});
  readers.push_back(
      {"cameras.json", "cameras.json",
       WrittenSeed("seed_cameras.json", [](const std::string& path) { relit::WriteCamerasFile(path, SeedCameras()); }),
       ReadWith([](const std::string& path) { relit::ReadCamerasFile(path); })});
  readers.push_back({"lights.json", "lights.json", WrittenSeed("seed_lights.json", [](const std::string& path) {
                       relit::LightsFile f;
                       for (int i = 0; i < 2; ++i) {
                         relit::FrameLight l;
                         l.view_frame = "view/00000" + std::to_string(i);
                         l.time_s = 0.1 * i;
                         l.position_m = Eigen::Vector3d(0.1, 0.2, 0.3 + i);
                         f.frames.push_back(l);
                       }
                       relit::WriteLightsFile(path, f);
                     }),
                     ReadWith([](const std::string& path) { relit::ReadLightsFile(path); })});
  readers.push_back({"proxy.json", "proxy.json", WrittenSeed("seed_proxy.json", [](const std::string& path) {
                       relit::ProxyFile f;
                       f.mesh = "reconstruct/proxy.obj";
                       f.object_radius_m = 0.1;
                       f.mattes.push_back({"view/000000", "reconstruct/mattes/0.png", "reconstruct/trimaps/0.png"});
                       relit::WriteProxyFile(path, f);
                     }),
                     ReadWith([](const std::string& path) { relit::ReadProxyFile(path); })});
  readers.push_back({"capture.json", "ws/capture/capture.json",
                     TextSeed("{\"schema\": \"relit.capture/1\",\n"
                              " \"inputs\": {\"view\": {\"output_width_px\": 64, \"output_height_px\": 48},\n"
                              "            \"light\": {\"output_width_px\": 64, \"output_height_px\": 48},\n"
                              "            \"geometry\": null},\n"
                              " \"sync\": {\"offset_s\": 0.25},\n"
                              " \"view_frames\": [{\"index\": 0, \"time_s\": 0.0, \"image\": \"view/000000.png\",\n"
                              "   \"linear\": \"view_linear/000000.exr\", \"light_frames\": [0]},\n"
                              "  {\"index\": 1, \"time_s\": 0.5, \"image\": \"view/000001.png\",\n"
                              "   \"linear\": \"view_linear/000001.exr\", \"light_frames\": [0]}],\n"
                              " \"light_frames\": [{\"index\": 0, \"time_s\": 0.2, \"image\": \"light/000000.png\"}],\n"
                              " \"geometry_frames\": []}\n"),
                     [](const fs::path& dir, const fs::path&) { relit::calib::ReadCaptureFile((dir / "ws").string()); }});
  // The same small sphere as OBJ and as PLY.
  const auto save_sphere = [](const std::string& path) {
    relit::render::SaveMesh(path, relit::render::MakeSphere(Eigen::Vector3f(0, 0, 0.1f), 0.05f, 8, 4));
  };
  const auto load_mesh = [](const std::string& path) { relit::render::LoadMesh(path); };
  readers.push_back({"obj", "mesh.obj", WrittenSeed("seed.obj", save_sphere), ReadWith(load_mesh)});
  readers.push_back({"ply", "mesh.ply", WrittenSeed("seed.ply", save_sphere), ReadWith(load_mesh)});
  readers.push_back({"exr", "image.exr", WrittenSeed("seed.exr", [](const std::string& path) {
                       relit::Image image(8, 8, {"R", "G", "B"});
                       for (size_t i = 0; i < image.data().size(); ++i) image.data()[i] = 0.01f * static_cast<float>(i);
                       relit::WriteImage(path, image);
                     }),
                     ReadWith([](const std::string& path) { relit::ReadImage(path); })});
  readers.push_back({"views.json", "views.json",
                     TextSeed("{\"views\": [\n"
                              " {\"name\": \"front\", \"cam_from_world\": {\"rotation_wxyz\": [1, 0, 0, 0], "
                              "\"translation_m\": [0, 0, 0.5]},\n"
                              "  \"intrinsics\": {\"width\": 32, \"height\": 24, \"fx\": 30, \"fy\": 30, "
                              "\"cx\": 15.5, \"cy\": 11.5, "
                              "\"distortion\": {\"k1\": 0, \"k2\": 0, \"p1\": 0, \"p2\": 0, \"k3\": 0}},\n"
                              "  \"light\": {\"type\": \"point\", \"position_m\": [0.3, 0, 0.4], "
                              "\"intensity\": 1.0}},\n"
                              " {\"name\": \"sun\", \"cam_from_world\": {\"rotation_wxyz\": [1, 0, 0, 0], "
                              "\"translation_m\": [0, 0, 0.5]},\n"
                              "  \"light\": {\"type\": \"directional\", \"direction_to_light\": [0, 0.5, 1], "
                              "\"irradiance\": [3, 3, 2.8]}},\n"
                              " {\"name\": \"box\", \"cam_from_world\": {\"rotation_wxyz\": [1, 0, 0, 0], "
                              "\"translation_m\": [0, 0, 0.5]},\n"
                              "  \"light\": {\"type\": \"area\", \"corner_m\": [0, 0, 1], \"edge_u_m\": [0.1, 0, 0], "
                              "\"edge_v_m\": [0, 0.1, 0], \"radiance\": 5}}\n"
                              "]}\n"),
                     [](const fs::path& dir, const fs::path& file) {
                       // An asset without models: a views file that passes
                       // every check then fails at "no mesh" (a relit::Error).
                       relit::relight::AssetDescription asset;
                       asset.camera.width = 32;
                       asset.camera.height = 24;
                       asset.camera.fx = asset.camera.fy = 30;
                       asset.mesh = (dir / "no_such_mesh.obj").string();
                       relit::RunRecord record("relit-bench-fuzz");
                       relit::relight::RenderStageOptions options;
                       relit::relight::RunRenderViews(asset, file.string(), (dir / "views_out").string(), options,
                                                      record, "cpu", /*force=*/true);
                     }});
  return readers;
}

struct Counts {
  int loaded = 0, refused = 0, unclear = 0, failed = 0;
  double total_s = 0, max_s = 0;
  std::map<std::string, int> unclear_kinds;  // first words of the messages
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"relit-bench-fuzz: mutated inputs for every reader; counts loaded / refused / unclear / failed "
               "and stops on a crash or hang (docs/benchmarks.md)"};
  int inputs = 2000;
  uint64_t seed = 1;
  double hang_s = 10;
  std::string only, save_dir = "fuzz-findings";
  app.add_option("--inputs", inputs, "mutants per reader")->check(CLI::Range(1, 10000000));
  app.add_option("--seed", seed, "random seed");
  app.add_option("--only", only, "comma-separated reader names (yaml, cameras.json, lights.json, proxy.json, "
                                 "capture.json, obj, ply, exr, views.json)");
  app.add_option("--hang-s", hang_s, "seconds one input may take before it counts as a hang");
  app.add_option("--save-dir", save_dir, "where failing, crashing or hanging inputs are saved");
  CLI11_PARSE(app, argc, argv);
  relit::InitLogging("", spdlog::level::off);
  relit::SetVerbosity(spdlog::level::off);
  // OpenMesh reports every bad PLY line on stderr; the counts say enough.
  omerr().disable();
  omlog().disable();
  omout().disable();

  const fs::path work = fs::temp_directory_path() / ("relit-fuzz-" + std::to_string(::getpid()));
  fs::create_directories(work);
  fs::create_directories(save_dir);
  for (int s : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) ::signal(s, OnCrash);
  std::atomic<bool> done{false};
  std::thread watchdog([&] {
    while (!done) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      if (g_running && NowMs() - g_started_ms > static_cast<int64_t>(hang_s * 1000)) {
        std::fprintf(stderr, "\nrelit-bench-fuzz: HANG (> %.0f s) in reader %s; input saved as %s\n", hang_s, g_reader,
                     g_saved_path);
        ::_exit(3);
      }
    }
  });

  bool bad = false;
  std::printf("| reader | inputs | loaded | refused (relit::Error) | unclear (other exception) | failed | "
              "mean ms | max ms |\n| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
  std::map<std::string, Counts> all;
  for (const Reader& reader : Readers()) {
    if (!only.empty() && ("," + only + ",").find("," + reader.name + ",") == std::string::npos) continue;
    const fs::path dir = work / reader.name;
    fs::create_directories(dir);
    const std::string seed_text = reader.seed(dir);
    const fs::path file = dir / reader.file;
    std::snprintf(g_reader, sizeof(g_reader), "%s", reader.name.c_str());
    std::mt19937_64 rng(seed ^ std::hash<std::string>{}(reader.name));
    Counts& c = all[reader.name];
    const std::string saved = (fs::path(save_dir) / ("last_" + reader.name)).string();
    std::snprintf(g_saved_path, sizeof(g_saved_path), "%s", saved.c_str());
    for (int i = 0; i <= inputs; ++i) {
      const std::string text = i == 0 ? seed_text : Mutate(seed_text, rng);  // input 0: the seed itself
      WriteText(file, text);
      WriteText(saved, text);  // for a crash or hang report
      const auto start = std::chrono::steady_clock::now();
      g_started_ms = NowMs();
      g_running = true;
      std::string failure;
      try {
        reader.read(dir, file);
        ++c.loaded;
      } catch (const relit::Error& e) {
        // views.json: the asset has no models, so a views file that passes
        // every check stops at the renderer; that counts as loaded.
        if (reader.name == "views.json" && std::string(e.what()).find("partitions listed") != std::string::npos) {
          ++c.loaded;
        } else {
          ++c.refused;
        }
        if (i == 0 && c.loaded == 0) std::fprintf(stderr, "relit-bench-fuzz: the %s seed is refused: %s\n", reader.name.c_str(), e.what());
      } catch (const std::bad_alloc&) {
        failure = "std::bad_alloc";
      } catch (const YAML::Exception& e) {
        ++c.unclear;
        ++c.unclear_kinds[std::string("YAML: ") + std::string(e.what()).substr(0, 50)];
      } catch (const nlohmann::json::exception& e) {
        ++c.unclear;
        ++c.unclear_kinds[std::string("JSON: ") + std::string(e.what()).substr(0, 50)];
      } catch (const std::exception& e) {
        failure = std::string("unexpected ") + e.what();
      }
      g_running = false;
      const double seconds = relit::SecondsSince(start);
      c.total_s += seconds;
      c.max_s = std::max(c.max_s, seconds);
      if (!failure.empty()) {
        ++c.failed;
        bad = true;
        const fs::path keep = fs::path(save_dir) / (reader.name + "_" + std::to_string(i));
        WriteText(keep, text);
        std::fprintf(stderr, "%s input %d: %s (saved as %s)\n", reader.name.c_str(), i, failure.c_str(),
                     keep.string().c_str());
      }
    }
    fs::remove(saved);
    std::printf("| %s | %d | %d | %d | %d | %d | %.2f | %.1f |\n", reader.name.c_str(), inputs + 1, c.loaded,
                c.refused, c.unclear, c.failed, 1000 * c.total_s / (inputs + 1), 1000 * c.max_s);
    std::fflush(stdout);
  }
  done = true;
  watchdog.join();
  for (const auto& [name, c] : all) {
    for (const auto& [kind, n] : c.unclear_kinds) std::printf("unclear in %s: %dx %s\n", name.c_str(), n, kind.c_str());
  }
  std::error_code ec;
  fs::remove_all(work, ec);
  std::printf("%s\n", bad ? "FAILED: see the inputs saved above" : "no crash, no hang, no failure");
  return bad ? 1 : 0;
}
