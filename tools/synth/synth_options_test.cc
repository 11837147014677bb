#include "tools/synth/synth_options.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <unistd.h>

#include "tools/synth/synth.h"

namespace relit::synth {
namespace {

SynthOptions Valid() {
  SynthOptions o = SynthOptions::ForSize("tiny");
  o.out = "/tmp/unused";
  return o;
}

void ExpectRejected(const SynthOptions& o, const std::string& fragment) {
  try {
    o.Check();
    ADD_FAILURE() << "accepted options that should fail with '" << fragment << "'";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(SynthOptions, SizesAreValid) {
  for (const std::string& size : SizeNames()) {
    SynthOptions o = SynthOptions::ForSize(size);
    o.out = "x";
    EXPECT_NO_THROW(o.Check()) << size;
  }
  EXPECT_GE(SynthOptions::ForSize("full").width_px, 640);
  EXPECT_GE(SynthOptions::ForSize("full").frames_per_video, 300);
  EXPECT_THROW(SynthOptions::ForSize("huge"), std::runtime_error);
}

TEST(SynthOptions, RejectsBadValues) {
  SynthOptions o = Valid();
  o.preset = "teapot";
  ExpectRejected(o, "unknown preset 'teapot'");
  o = Valid();
  o.out = "";
  ExpectRejected(o, "--out");
  o = Valid();
  o.width_px = 321;
  ExpectRejected(o, "even");
  o = Valid();
  o.distance_min_m = 0.8;
  ExpectRejected(o, "distance");
  o = Valid();
  o.elevation_min_deg = -10;
  ExpectRejected(o, "upper hemisphere");
  o = Valid();
  o.audio_offset_max_s = 5;
  ExpectRejected(o, "overlap");
  o = Valid();
  o.view_distortion = {0.1, 0.0};
  ExpectRejected(o, "5 numbers");
  o = Valid();
  o.board.squares_y = 4;
  ExpectRejected(o, "odd");
  o = Valid();
  o.display_rotation_deg = 45;
  ExpectRejected(o, "display_rotation_deg");
  o = Valid();
  o.light_display_rotation_deg = 45;
  ExpectRejected(o, "light_display_rotation_deg");
  o = Valid();
  o.light_width_px = 0;
  ExpectRejected(o, "both be 0");
  o = Valid();
  o.light_width_px = 353;
  ExpectRejected(o, "even");
  o = Valid();
  o.light_audio_start_s = 0.7;
  ExpectRejected(o, "light_audio_start_s");
  o = Valid();
  o.view_rolling_shutter_s = 0.04;
  ExpectRejected(o, "rolling_shutter_s");
  o = Valid();
  o.light_exposure_drift = 0.6;
  ExpectRejected(o, "exposure_drift");
  o = Valid();
  o.truth_only = o.eval_only = true;
  ExpectRejected(o, "exclude each other");
  o = Valid();
  o.eval_only = true;
  o.eval_views = 0;
  ExpectRejected(o, "eval_views > 0");
}

TEST(SynthOptions, YamlUnknownKeysAndTypesAreErrors) {
  SynthOptions o = Valid();
  OptionsReader typo = OptionsReader::FromString("preset: bunny\nsamples_per_pixle: 3\n", "synth.yaml");
  try {
    o.Read(typo);
    ADD_FAILURE() << "typo accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("samples_per_pixle"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("synth.yaml:2"), std::string::npos) << e.what();
  }
  OptionsReader nested = OptionsReader::FromString("board:\n  squares: 5\n", "synth.yaml");
  EXPECT_THROW(o.Read(nested), std::runtime_error);
  OptionsReader wrong_type = OptionsReader::FromString("width_px: wide\n", "synth.yaml");
  EXPECT_THROW(o.Read(wrong_type), std::runtime_error);

  OptionsReader good = OptionsReader::FromString(
      "preset: spheres\nseed: 5\nboard:\n  squares_x: 9\n  dictionary: DICT_APRILTAG_36h11\n", "synth.yaml");
  o = Valid();
  o.Read(good);
  EXPECT_EQ(o.preset, "spheres");
  EXPECT_EQ(o.seed, 5u);
  EXPECT_EQ(o.board.squares_x, 9);
  EXPECT_EQ(o.board.dictionary, "DICT_APRILTAG_36h11");
  EXPECT_NO_THROW(o.Check());
  EXPECT_EQ(o.ToJson()["board"]["squares_x"], 9);
}

TEST(SynthOptions, CommandLineRejectsBadInput) {
  const std::string dir = (std::filesystem::temp_directory_path() /
                           ("relit_synth_cli_" + std::to_string(::getpid()))).string();
  std::filesystem::create_directories(dir);
  const std::string config = dir + "/bad.yaml";
  std::ofstream(config) << "frames_per_vide: 10\n";
  {
    std::vector<std::string> args = {"relit-synth", "--config", config, "--out", dir + "/out"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    EXPECT_THROW(RunSynth(static_cast<int>(argv.size()), argv.data()), std::runtime_error);
  }
  {
    std::vector<std::string> args = {"relit-synth", "--preset", "teapot", "--out", dir + "/out"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    EXPECT_THROW(RunSynth(static_cast<int>(argv.size()), argv.data()), std::runtime_error);
  }
  {
    std::vector<std::string> args = {"relit-synth", "--size", "huge", "--out", dir + "/out"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    EXPECT_THROW(RunSynth(static_cast<int>(argv.size()), argv.data()), std::runtime_error);
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/out"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace relit::synth
