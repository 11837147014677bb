// relit-report on a real workspace: relit-synth renders the tiny spot
// capture, then the real capture, calib (board only) and reconstruct stages
// run on it. The relight stage is not finished yet, so this test writes
// minimal relight files itself (TEST INPUT, not stage output): a plan from
// the real partition layout and the calibrated cameras, synthetic training
// logs, turntable frames copied from the undistorted capture frames, and an
// eval table. The report is opened in headless Chromium (Debian `chromium`),
// which must load every image and print nothing to the console.
//
// The workspace is built once per test binary and shared by the test
// processes through a cache folder (file lock), like synth_render_test.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>

#include <gtest/gtest.h>

#include "calib/calib.h"
#include "capture/capture.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/options.h"
#include "core/shell.h"
#include "core/test_dir.h"
#include "core/workspace.h"
#include "reconstruct/reconstruct.h"
#include "relight/partitions.h"
#include "report/coverage.h"
#include "report/report.h"
#include "tools/synth/synth.h"
#include "tools/synth/truth.h"

namespace relit::report {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

void WriteText(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

// synth -> capture -> calib --no-sfm -> reconstruct into `dir`/ws.
void BuildWorkspace(const fs::path& dir) {
  const fs::path synth_dir = dir / "synth";
  synth::SynthOptions s = synth::SynthOptions::ForSize("tiny");
  s.preset = "spot";
  s.seed = 1;
  s.out = synth_dir.string();
  s.eval_views = 1;  // nothing here reads the evaluation set
  s.eval_samples_per_pixel = 1;
  s.geometry_pass = true;  // the report shows geometry-pass frames apart from both phones'
  synth::RunSynthImpl(s);
  const json truth = ReadJsonFile((synth_dir / "truth.json").string(), synth::kTruthKind, synth::kTruthVersion);
  const fs::path ws = dir / "ws";
  capture::CaptureOptions c;
  c.view = (synth_dir / "view.mp4").string();
  c.light = (synth_dir / "light.mp4").string();
  c.geometry = (synth_dir / "geometry.mp4").string();
  c.out = (ws / "capture").string();
  capture::RunCaptureImpl(c);
  calib::CalibOptions k;
  k.workspace = ws.string();
  k.board = BoardSpecFromJson(truth["board"], "truth.json: board");
  k.light.flash_offset_m = truth["flash"]["offset_cam_m"].get<std::vector<double>>();
  k.sfm.enabled = false;
  calib::RunCalibImpl(k);
  reconstruct::ReconstructOptions r;
  r.workspace = ws.string();
  r.proxy.method = "mesh";  // the synthetic object as "user mesh": fast and exact
  r.mesh = (synth_dir / truth["objects"][0]["mesh"].get<std::string>()).string();
  r.cleanup.target_faces = 3000;
  r.max_matte_frames = 8;
  reconstruct::RunReconstructImpl(r);
}

struct BrowserResult {
  std::string dom;
  std::vector<std::string> console;  // CONSOLE lines of chromium's log
  int exit_code = -1;
};

BrowserResult OpenInChromium(const fs::path& html, const fs::path& scratch) {
  const char* env = std::getenv("RELIT_CHROMIUM");
  const std::string browser = env != nullptr && *env != '\0' ? env : "chromium";
  fs::create_directories(scratch);
  const fs::path dom = scratch / "dom.html", log = scratch / "chromium.log";
  const std::string command =
      "timeout 180 " + ShellQuote(browser) + " --headless --disable-gpu --no-sandbox --no-first-run " +
      "--user-data-dir=" + ShellQuote((scratch / "profile").string()) +
      " --enable-logging=stderr --v=0 --virtual-time-budget=10000 --dump-dom " +
      ShellQuote("file://" + fs::absolute(html).string()) + " > " + ShellQuote(dom.string()) + " 2> " +
      ShellQuote(log.string());
  BrowserResult result;
  result.exit_code = std::system(command.c_str());
  std::ifstream d(dom);
  result.dom.assign(std::istreambuf_iterator<char>(d), std::istreambuf_iterator<char>());
  std::ifstream l(log);
  for (std::string line; std::getline(l, line);) {
    if (line.find(":CONSOLE") != std::string::npos) result.console.push_back(line);
  }
  return result;
}

std::vector<std::string> ImageSources(const std::string& html) {
  std::vector<std::string> sources;
  const std::regex img("<img src=\"([^\"]+)\"");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), img); it != std::sregex_iterator(); ++it) {
    sources.push_back((*it)[1]);
  }
  return sources;
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

class ReportWorkspaceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scratch_ = new fs::path(fs::temp_directory_path() / ("relit_report_test_" + std::to_string(::getpid())));
    fs::create_directories(*scratch_);
    const test_support::BuildCache build_cache = test_support::TestBuildCache("relit_report_test_cache_");
    const fs::path& cache = build_cache.dir;
    cached_ = new fs::path(cache / ("ws_" + build_cache.build_key));
    const int lock = ::open((cache / "lock").c_str(), O_CREAT | O_RDWR, 0644);
    ASSERT_GE(lock, 0);
    ASSERT_EQ(::flock(lock, LOCK_EX), 0);
    if (!fs::exists(*cached_ / "ws" / "reconstruct" / "proxy.json")) {
      // Workspaces of older builds and half-built ones of crashed runs (the lock is held).
      for (const auto& entry : fs::directory_iterator(cache)) {
        if (entry.path().filename() != "lock") fs::remove_all(entry.path());
      }
      const fs::path building = cache / ("building_" + std::to_string(::getpid()));
      fs::remove_all(building);
      BuildWorkspace(building);
      fs::rename(building, *cached_);
    }
    ::flock(lock, LOCK_UN);
    ::close(lock);
  }
  static void TearDownTestSuite() {
    std::error_code ignored;
    fs::remove_all(*scratch_, ignored);
    delete scratch_;
    delete cached_;
  }

  // A workspace of its own (the report and relight files are written into
  // it) whose stage folders link to the cached ones.
  static fs::path Workspace(const std::string& name, const std::vector<std::string>& stages) {
    const fs::path ws = *scratch_ / name;
    fs::create_directories(ws);
    for (const std::string& stage : stages) fs::create_directory_symlink(*cached_ / "ws" / stage, ws / stage);
    return ws;
  }

  // TEST INPUT standing in for relit-relight until it exists (see the top).
  static void WriteRelightFiles(const fs::path& ws) {
    const CamerasFile cameras = ReadCamerasFile((ws / "calib" / "cameras.json").string());
    const ProxyFile proxy = ReadProxyFile((ws / "reconstruct" / "proxy.json").string());
    std::vector<Eigen::Vector3d> directions;
    std::vector<std::string> names;
    for (const CalibratedFrame* f : cameras.FramesOf("view")) {
      directions.push_back(f->cam_from_world.Inverse().translation - proxy.object_centre_m);
      names.push_back(f->name.substr(f->name.find('/') + 1));
    }
    const relight::PartitionLayout layout = relight::PartitionLayout::Dnl13();
    const auto assigned = layout.AssignFrames(directions);
    json plan = {{"layout", layout.ToJson()}, {"partitions", json::array()}};
    std::vector<int> trained;
    for (size_t k = 0; k < assigned.size(); ++k) {
      json train = json::array(), validation = json::array();
      for (size_t i = 0; i < assigned[k].size(); ++i) {
        (i % 5 == 4 ? validation : train).push_back(names[assigned[k][i]]);
      }
      plan["partitions"].push_back({{"index", k},
                                    {"direction", ToJson(layout.vertices()[k])},
                                    {"train_frames", train},
                                    {"validation_frames", validation}});
      char dir[24];
      std::snprintf(dir, sizeof(dir), "%02zu", k);
      const fs::path p = ws / "relight" / "partitions" / dir;
      if (train.empty()) {
        WriteText(p / "train.json", json({{"skipped", "no training frames"}}).dump());
        continue;
      }
      trained.push_back(static_cast<int>(k));
      std::string log;
      for (int step = 0; step <= 2000; step += 100) {
        const double loss = 0.2 * std::exp(-step / 600.0) + 0.01 + 0.001 * k;
        // The second trained partition has no mask network (mask loss 0).
        const double mask_loss = trained.size() == 2 ? 0.0 : 0.2 * loss;
        log += json({{"step", step}, {"time_s", step * 0.05}, {"loss", loss}, {"rgb_loss", 0.8 * loss},
                     {"mask_loss", mask_loss}}).dump() + "\n";
        if (step % 500 == 0) log += json({{"step", step}, {"val_psnr_db", 18 + 10 * (1 - std::exp(-step / 700.0))},
                                          {"val_mae", 0.05 * std::exp(-step / 700.0)}}).dump() + "\n";
      }
      WriteText(p / "log.jsonl", log);
      if (trained.size() == 1) WriteText(p / "train.json", json({{"final_loss", 0.011}}).dump());
    }
    WriteJsonFile((ws / "relight" / "plan" / "plan.json").string(), "relight_plan", 1, plan);
    int n = 0;
    for (const CalibratedFrame* f : cameras.FramesOf("view")) {
      if (n >= 12) break;
      char name[16];
      std::snprintf(name, sizeof(name), "%04d.png", n++);
      for (const std::string turntable : {"turntable_point", "turntable_env"}) {
        fs::create_directories(ws / "relight" / "render" / turntable);
        fs::copy_file(ws / f->image_8bit, ws / "relight" / "render" / turntable / name);
      }
    }
    WriteText(ws / "relight" / "render" / "turntable_point.mp4", "not a video: the report only links it");
    // relight/eval as `relit-relight eval` writes it (relit.eval/1), with
    // capture frames standing in for its PNGs.
    const fs::path png = ws / cameras.FramesOf("view")[0]->image_8bit;
    json images = json::array(), summary = json::array();
    for (const std::string view : {"eval_00", "eval_01"}) {
      const fs::path dir = ws / "relight" / "eval" / "images" / view;
      fs::create_directories(dir);
      fs::copy_file(png, dir / "point_00_gt.png", fs::copy_options::overwrite_existing);
      for (const std::string method : {"model", "cues_only"}) {
        for (const std::string suffix : {"", "_error"}) {
          fs::copy_file(png, dir / ("point_00_" + method + suffix + ".png"), fs::copy_options::overwrite_existing);
        }
        const std::string stem = "images/" + view + "/point_00_";
        images.push_back({{"view", view}, {"light", "point_00"}, {"light_type", "point"}, {"method", method},
                          {"psnr_db", view == "eval_00" ? 27.5 : 26.1}, {"mae", 0.02}, {"ssim", 0.91},
                          {"alpha_mae", 0.01}, {"render_png", stem + method + ".png"},
                          {"error_png", stem + method + "_error.png"}, {"reference_png", stem + "gt.png"}});
      }
    }
    for (const std::string method : {"model", "cues_only"}) {
      for (const std::string type : {"point", "all"}) {
        // The floor is 32: the model 5.2 dB below it (marked), cues-only 7.8.
        summary.push_back({{"method", method}, {"light_type", type}, {"images", 2},
                           {"psnr_db", method == "model" ? 26.8 : 24.2}, {"mae", 0.02}, {"ssim", 0.9},
                           {"alpha_mae", 0.01}, {"truth_floor_margin_db", method == "model" ? 5.2 : 7.8}});
      }
    }
    WriteJsonFile((ws / "relight" / "eval" / "eval.json").string(), "eval", 1,
                  {{"methods", {"model", "cues_only"}}, {"light_types", {"point"}}, {"views", 2}, {"lights", 1},
                   {"light_unit", {{"factor", 1.43}, {"exposure", 1.0}}}, {"options", {{"error_map_scale", 5}}},
                   {"summary", summary}, {"images", images},
                   {"truth_noise_floor",
                    {{"per_light_type", {{"point", {{"psnr_db", 32.0}, {"mae", 0.004}}}, {"all", {{"psnr_db", 32.0}, {"mae", 0.004}}}}},
                     {"min_margin_db", 6.0}, {"scores_within_min_margin", 2}}}});
    WriteText(ws / "relight" / "eval" / "eval.md", "| method | point |\n| model | 26.80 / 0.0200 / 0.900 |\n");
  }

  static fs::path* scratch_;
  static fs::path* cached_;
};
fs::path* ReportWorkspaceTest::scratch_ = nullptr;
fs::path* ReportWorkspaceTest::cached_ = nullptr;

TEST_F(ReportWorkspaceTest, FullWorkspaceLoadsInChromiumWithoutErrors) {
  const fs::path ws = Workspace("full", {"capture", "calib", "reconstruct"});
  WriteRelightFiles(ws);
  ReportOptions options;
  options.workspace = ws.string();
  const ReportSummary summary = RunReportImpl(options);
  EXPECT_TRUE(summary.sections_failed.empty()) << summary.sections_failed.front();
  EXPECT_TRUE(summary.sections_not_run.empty()) << summary.sections_not_run.front();
  std::printf("report: %.1f s, %zu warnings\n", summary.seconds, summary.warnings.size());
  for (const std::string& w : summary.warnings) std::printf("  warning: %s\n", w.c_str());

  const std::string html = ReadFile(ws / "report" / "index.html");
  const std::vector<std::string> sources = ImageSources(html);
  EXPECT_GE(sources.size(), 30u);  // plots, previews, atlas, samples, training curves, strips
  std::set<std::string> kinds;
  for (const std::string& src : sources) {
    EXPECT_TRUE(fs::is_regular_file(ws / "report" / src)) << src;
    EXPECT_EQ(src.rfind("assets/", 0), 0u) << src << " is outside the report folder";
    kinds.insert(fs::path(src).extension().string());
  }
  EXPECT_EQ(kinds, (std::set<std::string>{".png", ".svg"}));
  for (const std::string part : {"coverage_hemisphere.svg", "proxy_preview_0.png", "atlas_preview.png",
                                 "_trimap.png", "_matte.png", "training_psnr_all.svg", "turntable_env_",
                                 "capture_frames.svg", "trajectories_top.svg", "eval_01", "26.80 / 0.0200 / 0.900 *",
                                 "24.20 / 0.0200 / 0.900<", "truth noise floor", "32.00 / 0.0040", "scores within 6 dB of it",
                                 "eval_eval_00_point_00_gt.png", "eval_eval_00_point_00_cues_only_error.png",
                                 "Geometry pass: ", "geometry pass (phone V)"}) {
    EXPECT_NE(html.find(part), std::string::npos) << part;
  }
  int loss_plots = 0, with_mask = 0;  // every partition's curves but the one without a mask network
  for (const std::string& src : sources) {
    if (src.find("_loss.svg") == std::string::npos) continue;
    ++loss_plots;
    with_mask += ReadFile(ws / "report" / src).find(">mask") != std::string::npos;
  }
  EXPECT_GE(loss_plots, 2);
  EXPECT_EQ(with_mask, loss_plots - 1);
  for (const std::string& src : sources) {
    if (src.find("trajectories_top.svg") == std::string::npos) continue;
    EXPECT_NE(ReadFile(ws / "report" / src).find("geometry pass"), std::string::npos) << src;
  }
  EXPECT_EQ(html.find("http://"), std::string::npos);  // nothing fetched from the network
  EXPECT_EQ(html.find("https://"), std::string::npos);

  const BrowserResult browser = OpenInChromium(ws / "report" / "index.html", *scratch_ / "chromium_full");
  ASSERT_EQ(browser.exit_code, 0) << "chromium failed; install it with tools/install-deps";
  EXPECT_NE(browser.dom.find("data-image-check=\"ok images=" + std::to_string(sources.size()) + " broken=0\""),
            std::string::npos)
      << browser.dom.substr(0, 2000);
  EXPECT_TRUE(browser.console.empty()) << browser.console.front();
}

// The coverage figures the report computes from calib/ agree with the same
// statistics on the ground-truth camera centres and flash positions.
TEST_F(ReportWorkspaceTest, CoverageAgreesWithGroundTruth) {
  const fs::path ws = Workspace("coverage", {"capture", "calib", "reconstruct"});
  ReportOptions options;
  options.workspace = ws.string();
  options.mesh_preview.views = 0;
  const json measured = RunReportImpl(options).results.at("coverage");
  const json truth = ReadJsonFile((*cached_ / "synth" / "truth.json").string(), synth::kTruthKind,
                                  synth::kTruthVersion);
  const json capture = ReadJsonFile((ws / "capture" / "capture.json").string(), "capture", 1);
  const LightsFile lights = ReadLightsFile((ws / "calib" / "lights.json").string());
  const Eigen::Vector3d centre = Vector3FromJson(measured.at("object_centre_m"));
  std::vector<Eigen::Vector3d> views, flashes;
  for (const FrameLight& l : lights.frames) {
    const int index = std::stoi(l.view_frame.substr(l.view_frame.find('/') + 1));
    int source = -1;
    for (const json& f : capture["view_frames"]) {
      if (f["index"] == index) source = f["source_frame"];
    }
    ASSERT_GE(source, 0) << l.view_frame;
    const json& t = truth["videos"]["view"]["frames"][source];
    views.push_back(Vector3FromJson(t["camera_center_world_m"]) - centre);
    flashes.push_back(Vector3FromJson(t["light_position_world_m"]) - centre);
  }
  const CoverageStats expected = ComputeCoverage(views, flashes, CoverageThresholds{});
  std::printf("coverage measured / truth: view spread %.2f / %.2f, light spread %.2f / %.2f, relative %.2f / %.2f, "
              "median angle %.2f / %.2f deg, %d frames\n",
              measured["view_spread_deg"].get<double>(), expected.view_spread_deg,
              measured["light_spread_deg"].get<double>(), expected.light_spread_deg,
              measured["relative_light_spread_deg"].get<double>(), expected.relative_light_spread_deg,
              measured["median_view_light_angle_deg"].get<double>(), expected.median_view_light_angle_deg,
              expected.frames);
  EXPECT_EQ(measured["frames"].get<int>(), expected.frames);
  EXPECT_GE(expected.frames, 10);
  // Calibration is good to millimetres at ~0.35 m: directions agree to well under a degree.
  EXPECT_NEAR(measured["view_spread_deg"].get<double>(), expected.view_spread_deg, 1.0);
  EXPECT_NEAR(measured["light_spread_deg"].get<double>(), expected.light_spread_deg, 1.0);
  EXPECT_NEAR(measured["relative_light_spread_deg"].get<double>(), expected.relative_light_spread_deg, 1.0);
  EXPECT_NEAR(measured["median_view_light_angle_deg"].get<double>(), expected.median_view_light_angle_deg, 1.5);
  EXPECT_EQ(measured["warnings"].size(), expected.warnings.size());
}

TEST_F(ReportWorkspaceTest, BrokenImageIsCaughtByTheBrowserCheck) {
  const fs::path ws = Workspace("broken", {"capture", "calib"});
  ReportOptions options;
  options.workspace = ws.string();
  const ReportSummary summary = RunReportImpl(options);
  EXPECT_EQ(summary.sections_not_run,
            (std::vector<std::string>{"reconstruct", "training", "render", "eval"}));
  fs::remove(ws / "report" / "assets" / "coverage_hemisphere.svg");
  const BrowserResult browser = OpenInChromium(ws / "report" / "index.html", *scratch_ / "chromium_broken");
  ASSERT_EQ(browser.exit_code, 0);
  EXPECT_NE(browser.dom.find("broken=1\""), std::string::npos) << browser.dom.substr(0, 2000);
  ASSERT_EQ(browser.console.size(), 1u);
  EXPECT_NE(browser.console[0].find("coverage_hemisphere.svg"), std::string::npos);
}

TEST_F(ReportWorkspaceTest, EmptyWorkspaceSaysNotRunYet) {
  const fs::path ws = *scratch_ / "empty";
  fs::create_directories(ws);
  ReportOptions options;
  options.workspace = ws.string();
  const ReportSummary summary = RunReportImpl(options);
  EXPECT_EQ(summary.sections_not_run.size(), 7u);
  const std::string html = ReadFile(ws / "report" / "index.html");
  EXPECT_NE(html.find("Not run yet: W/capture/capture.json does not exist"), std::string::npos);
  const BrowserResult browser = OpenInChromium(ws / "report" / "index.html", *scratch_ / "chromium_empty");
  ASSERT_EQ(browser.exit_code, 0);
  EXPECT_NE(browser.dom.find("data-image-check=\"ok images=0 broken=0\""), std::string::npos);
  EXPECT_TRUE(browser.console.empty()) << browser.console.front();
  // A rerun replaces the report as a whole (atomic folder).
  fs::create_directories(ws / "report" / "stale");
  RunReportImpl(options);
  EXPECT_FALSE(fs::exists(ws / "report" / "stale"));
}

TEST_F(ReportWorkspaceTest, UnreadableFilesAreShownNotFatal) {
  const fs::path ws = Workspace("unreadable", {"capture"});
  WriteText(ws / "relight" / "partitions" / "03" / "log.jsonl", "{\"step\": 0, \"loss\": 1}\nnot json\n");
  WriteText(ws / "calib" / "cameras.json", "{\"schema\": \"relit.cameras/99\"}");
  ReportOptions options;
  options.workspace = ws.string();
  const ReportSummary summary = RunReportImpl(options);
  EXPECT_EQ(summary.sections_failed, (std::vector<std::string>{"calib", "training"}));
  const std::string html = ReadFile(ws / "report" / "index.html");
  EXPECT_NE(html.find("log.jsonl:2: not a JSON line"), std::string::npos);
  EXPECT_NE(html.find("relit.cameras/99"), std::string::npos);
  EXPECT_NE(html.find("Phone V frames"), std::string::npos);  // the capture section is still there
}

TEST(ReportOptionsTest, UnknownKeysAndBadValuesAreErrors) {
  ReportOptions o;
  OptionsReader ok = OptionsReader::FromString("thumbnail_width_px: 200\nmesh_preview: {views: 2}\n"
                                               "coverage: {min_view_spread_deg: 30}\n");
  ReadOptions(ok, &o);
  EXPECT_EQ(o.thumbnail_width_px, 200);
  EXPECT_EQ(o.mesh_preview.views, 2);
  EXPECT_EQ(o.coverage.min_view_spread_deg, 30);
  ReportOptions bad;
  OptionsReader typo = OptionsReader::FromString("mesh_preview: {veiws: 2}\n");
  EXPECT_THROW(ReadOptions(typo, &bad), Error);
  OptionsReader range = OptionsReader::FromString("thumbnail_width_px: 5\n");
  EXPECT_THROW(ReadOptions(range, &bad), Error);
  ReportOptions missing;
  EXPECT_THROW(RunReportImpl(missing), Error);
  missing.workspace = "/nonexistent/relit/workspace";
  EXPECT_THROW(RunReportImpl(missing), Error);
}

}  // namespace
}  // namespace relit::report
