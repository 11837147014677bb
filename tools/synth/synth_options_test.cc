#include "tools/synth/synth_options.h"

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/test_dir.h"
#include "tools/synth/synth.h"

namespace relit::synth {
namespace {

SynthOptions Valid() {
  SynthOptions o = SynthOptions::ForSize("tiny");
  o.out = "/tmp/unused";
  return o;
}

// RunSynth with these arguments (argv[0] first).
int RunSynthWith(std::vector<std::string> args) {
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  return RunSynth(static_cast<int>(argv.size()), argv.data());
}

void ExpectRejected(const SynthOptions& o, const std::string& fragment) {
  try {
    CheckOptions(o);
    ADD_FAILURE() << "accepted options that should fail with '" << fragment << "'";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(SynthOptions, SizesAreValid) {
  for (const std::string& size : SizeNames()) {
    SynthOptions o = SynthOptions::ForSize(size);
    o.out = "x";
    EXPECT_NO_THROW(CheckOptions(o)) << size;
  }
  EXPECT_GE(SynthOptions::ForSize("full").width_px, 640);
  EXPECT_GE(SynthOptions::ForSize("full").frames_per_video, 300);
  EXPECT_THROW(SynthOptions::ForSize("huge"), std::runtime_error);
}

TEST(SynthOptions, RejectsBadValues) {
  const std::vector<std::pair<std::function<void(SynthOptions&)>, std::string>> cases = {
      {[](SynthOptions& o) { o.preset = "teapot"; }, "'teapot' is not one of"},
      {[](SynthOptions& o) { o.out = ""; }, "--out"},
      {[](SynthOptions& o) { o.width_px = 321; }, "even"},
      {[](SynthOptions& o) { o.distance_min_m = 0.8; }, "distance"},
      {[](SynthOptions& o) { o.elevation_min_deg = -10; }, "upper hemisphere"},
      {[](SynthOptions& o) { o.audio_offset_max_s = 5; }, "overlap"},
      {[](SynthOptions& o) { o.view_distortion = {0.1, 0.0}; }, "5 numbers"},
      {[](SynthOptions& o) { o.board.squares_y = 4; }, "odd"},
      {[](SynthOptions& o) { o.display_rotation_deg = 45; }, "display_rotation_deg"},
      {[](SynthOptions& o) { o.light_display_rotation_deg = 45; }, "light_display_rotation_deg"},
      {[](SynthOptions& o) { o.light_width_px = 0; }, "both be 0"},
      {[](SynthOptions& o) { o.light_width_px = 353; }, "even"},
      {[](SynthOptions& o) { o.light_audio_start_s = 0.7; }, "light_audio_start_s"},
      {[](SynthOptions& o) { o.view_rolling_shutter_s = 0.04; }, "rolling_shutter_s"},
      {[](SynthOptions& o) { o.light_exposure_drift = 0.6; }, "exposure_drift"},
      {[](SynthOptions& o) { o.truth_only = o.eval_only = true; }, "exclude each other"},
      {[](SynthOptions& o) {
         o.eval_only = true;
         o.eval_views = 0;
       }, "eval_views > 0"},
      {[](SynthOptions& o) { o.roll_max_deg = 50; }, "roll_max_deg"},
      {[](SynthOptions& o) { o.exposure = 0; }, "exposure must be > 0"}};
  for (const auto& [mutate, fragment] : cases) {
    SynthOptions o = Valid();
    mutate(o);
    ExpectRejected(o, fragment);
  }
}

TEST(SynthOptions, YamlUnknownKeysAndTypesAreErrors) {
  SynthOptions o = Valid();
  OptionsReader typo = OptionsReader::FromString("preset: bunny\nsamples_per_pixle: 3\n", "synth.yaml");
  try {
    ReadOptions(typo, &o);
    ADD_FAILURE() << "typo accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("samples_per_pixle"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("synth.yaml:2"), std::string::npos) << e.what();
  }
  OptionsReader nested = OptionsReader::FromString("board:\n  squares: 5\n", "synth.yaml");
  EXPECT_THROW(ReadOptions(nested, &o), std::runtime_error);
  OptionsReader wrong_type = OptionsReader::FromString("width_px: wide\n", "synth.yaml");
  EXPECT_THROW(ReadOptions(wrong_type, &o), std::runtime_error);

  OptionsReader good = OptionsReader::FromString(
      "preset: spheres\nseed: 5\nboard:\n  squares_x: 9\n  dictionary: DICT_APRILTAG_36h11\n", "synth.yaml");
  o = Valid();
  ReadOptions(good, &o);
  EXPECT_EQ(o.preset, "spheres");
  EXPECT_EQ(o.seed, 5u);
  EXPECT_EQ(o.board.squares_x, 9);
  EXPECT_EQ(o.board.dictionary, "DICT_APRILTAG_36h11");
  EXPECT_NO_THROW(CheckOptions(o));
  EXPECT_EQ(OptionsToJson(o)["board"]["squares_x"], 9);
}

class SynthOptionsFile : public test_support::TempDirTest {
 protected:
  SynthOptionsFile() : TempDirTest("relit_synth_file_") {}
};

TEST_F(SynthOptionsFile, ReadOnTheDefaultsOfItsSize) {
  const std::string config = (root_ / "demo.yaml").string();
  std::ofstream(config) << "size: demo\nseed: 9\n";
  const SynthOptions demo = SynthOptions::FromFile(config, "", "tiny");  // the file's size
  EXPECT_EQ(demo.size, "demo");
  EXPECT_EQ(demo.width_px, SynthOptions::ForSize("demo").width_px);
  EXPECT_EQ(demo.seed, 9u);
  const SynthOptions tiny = SynthOptions::FromFile(config, "tiny", "full");  // the given size wins
  EXPECT_EQ(tiny.size, "tiny");
  EXPECT_EQ(tiny.width_px, SynthOptions::ForSize("tiny").width_px);
  EXPECT_EQ(tiny.seed, 9u);
  EXPECT_EQ(SynthOptions::FromFile("", "", "full").width_px, SynthOptions::ForSize("full").width_px);
}

TEST(SynthOptions, CommandLineRejectsBadInput) {
  const std::string dir = (std::filesystem::temp_directory_path() /
                           ("relit_synth_cli_" + std::to_string(::getpid()))).string();
  std::filesystem::create_directories(dir);
  const std::string config = dir + "/bad.yaml";
  std::ofstream(config) << "frames_per_vide: 10\n";
  EXPECT_THROW(RunSynthWith({"relit-synth", "--config", config, "--out", dir + "/out"}), std::runtime_error);
  EXPECT_THROW(RunSynthWith({"relit-synth", "--preset", "teapot", "--out", dir + "/out"}), std::runtime_error);
  EXPECT_THROW(RunSynthWith({"relit-synth", "--size", "huge", "--out", dir + "/out"}), std::runtime_error);
  EXPECT_FALSE(std::filesystem::exists(dir + "/out"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace relit::synth
