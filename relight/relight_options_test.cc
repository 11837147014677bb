// The relight: section's field tables: the records they write are those of
// relit before them (resume fingerprints hash them), reading refuses what it
// refused, checks run across fields and sections.
#include "relight/relight_options.h"

#include <fstream>
#include <string>
#include <utility>
#include <vector>

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
  // A section and a part of the message it is refused with.
  const std::vector<std::pair<std::string, std::string>> refused = {
      {"train: {stesp: 5}\n", "r.yaml:1: unknown key 'train.stesp', did you mean 'steps'?"},
      {"train: {learning_rat: 0.1}\n", "did you mean 'learning_rate'?"},
      {"workspace: W\n", "unknown key 'workspace'"},
      {"model: {norm: batch}\n", "key 'model.norm': 'batch' is not one of instance, none"},
      {"cues: {samples_per_pixel: 0}\n", "value 0 is out of range [1, 65536]"},
      {"train: {cue_fit: {ridge: 0}}\n", "key 'train.cue_fit.ridge'"},
      {"eval: {methods: [model, nerf]}\n", "'nerf' is not one of model"},
      {"log_level: loud\n", "'loud' is not one of trace"},
      // Checks across fields and sections run when the section is read.
      {"cues: {input: sh}\nmodel: {variant: dnl}\n", "support_plane needs input: radiance"},
      {"cues: {input: sh, support_plane: false}\n", "variant residual"},
      {"render: {width_px: 64}\n", "render: width_px and height_px must both be 0"},
      {"partitions: {elevation_deg: [10]}\n", "only used with layout: custom"},
      {"dataset: {holdout_every: 1}\n", "holdout_every must be 0"},
      {"augment: {map_width_px: 17}\n", "map_width_px must be even"},
      {"export: {bake_texture_px: 100}\n", "bake_texture_px must be a power of two"},
      {"eval: {methods: [model, model]}\n", "lists 'model' twice"},
      {"eval: {cue_fit: {saturation_level: -0.5}}\n", "saturation_level must be >= 0 or -1"}};
  for (const auto& [yaml, part] : refused) {
    EXPECT_NE(ReadError(yaml).find(part), std::string::npos) << yaml << ": " << ReadError(yaml);
  }
  EXPECT_EQ(ReadError("train: {crop_px: 30}\n"), "train: crop_px must be 0 (no crop) or a multiple of 4 that is >= 8, got 30");
  EXPECT_EQ(ReadError("cues: {paper_albedo: 0.1, ink_albedo: 0.2}\n"),
            "cues: ink_albedo (0.2) must not exceed paper_albedo (0.1)");
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
