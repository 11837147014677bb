// The relight: section's field tables: the records they write are those of
// relit before them (resume fingerprints hash them), reading refuses what it
// refused, checks run across fields and sections.
#include "relight/relight_options.h"

#include <fstream>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/options.h"

namespace relit::relight {
namespace {

using nlohmann::json;

// The error message of reading `yaml` as a relight: section, "" when it reads.
std::string ReadError(const std::string& yaml) {
  try {
    OptionsReader reader = OptionsReader::FromString(yaml, "r.yaml");
    ReadRelightSection(reader);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(RelightOptions, RecordsAreThoseOfBeforeTheFieldTables) {
  std::ifstream in(std::string(RELIT_SOURCE_DIR) + "/relight/testdata/options_records.json");
  ASSERT_TRUE(in);
  const json cases = json::parse(in).at("cases");
  ASSERT_EQ(cases.size(), 4u);
  for (const json& c : cases) {
    OptionsReader reader = OptionsReader::FromString(c.at("yaml").get<std::string>());
    RelightOptions options = ReadRelightSection(reader);
    options.workspace = "W";
    // dump(): the fingerprints hash the text, so 1 and 1.0 differ.
    EXPECT_EQ(OptionsToJson(options).dump(), c.at("record").dump()) << c.at("name");
  }
}

TEST(RelightOptions, ReadingRefusesWhatItRefused) {
  EXPECT_EQ(ReadError("train: {steps: 5}\npartitions: {layout: single}\n"), "");
  EXPECT_NE(ReadError("train: {stesp: 5}\n").find("r.yaml:1: unknown key 'train.stesp', did you mean 'steps'?"),
            std::string::npos);
  EXPECT_NE(ReadError("train: {learning_rat: 0.1}\n").find("did you mean 'learning_rate'?"), std::string::npos);
  EXPECT_NE(ReadError("workspace: W\n").find("unknown key 'workspace'"), std::string::npos);
  EXPECT_NE(ReadError("model: {norm: batch}\n").find("key 'model.norm': 'batch' is not one of instance, none"),
            std::string::npos);
  EXPECT_NE(ReadError("cues: {samples_per_pixel: 0}\n").find("value 0 is out of range [1, 65536]"),
            std::string::npos);
  EXPECT_NE(ReadError("train: {cue_fit: {ridge: 0}}\n").find("key 'train.cue_fit.ridge'"), std::string::npos);
  EXPECT_NE(ReadError("eval: {methods: [model, nerf]}\n").find("'nerf' is not one of model"), std::string::npos);
  EXPECT_NE(ReadError("log_level: loud\n").find("'loud' is not one of trace"), std::string::npos);
  // Checks across fields and sections run when the section is read.
  EXPECT_EQ(ReadError("train: {crop_px: 30}\n"), "train: crop_px must be 0 (no crop) or a multiple of 4 that is >= 8, got 30");
  EXPECT_EQ(ReadError("cues: {paper_albedo: 0.1, ink_albedo: 0.2}\n"),
            "cues: ink_albedo (0.2) must not exceed paper_albedo (0.1)");
  EXPECT_NE(ReadError("cues: {input: sh}\nmodel: {variant: dnl}\n").find("support_plane needs input: radiance"),
            std::string::npos);
  EXPECT_NE(ReadError("cues: {input: sh, support_plane: false}\n").find("variant residual"), std::string::npos);
  EXPECT_NE(ReadError("render: {width_px: 64}\n").find("render: width_px and height_px must both be 0"),
            std::string::npos);
  EXPECT_NE(ReadError("partitions: {elevation_deg: [10]}\n").find("only used with layout: custom"),
            std::string::npos);
  EXPECT_NE(ReadError("dataset: {holdout_every: 1}\n").find("holdout_every must be 0"), std::string::npos);
  EXPECT_NE(ReadError("augment: {map_width_px: 17}\n").find("map_width_px must be even"), std::string::npos);
  EXPECT_NE(ReadError("export: {bake_texture_px: 100}\n").find("bake_texture_px must be a power of two"),
            std::string::npos);
  EXPECT_NE(ReadError("eval: {methods: [model, model]}\n").find("lists 'model' twice"), std::string::npos);
  EXPECT_NE(ReadError("eval: {cue_fit: {saturation_level: -0.5}}\n").find("saturation_level must be >= 0 or -1"),
            std::string::npos);
}

TEST(RelightOptions, ReadingCopiesTheCuesFormatIntoTheModel) {
  OptionsReader reader = OptionsReader::FromString("cues: {bases: [lambert]}\nmodel: {variant: dnl}\n");
  const RelightOptions options = ReadRelightSection(reader);
  EXPECT_EQ(options.model.format.bases, std::vector<std::string>{"lambert"});
  EXPECT_EQ(OptionsToJson(options.model).at("bases"), json({"lambert"}));
}

TEST(RelightOptions, CheckOptionsChecksCodeBuiltOptions) {
  RelightOptions options;
  EXPECT_NO_THROW(CheckOptions(options));
  options.train.optimizer.threads = 0;
  EXPECT_THROW(CheckOptions(options), Error);
  options = RelightOptions();
  options.render.point_light_offset_m = {0, 0};
  EXPECT_THROW(CheckOptions(options), Error);
  options = RelightOptions();
  options.train.optimizer.cue_fit.max_pixels = 10;
  EXPECT_THROW(CheckOptions(options), Error);
}

}  // namespace
}  // namespace relit::relight
