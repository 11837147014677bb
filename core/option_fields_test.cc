#include "core/option_fields.h"

#include <gtest/gtest.h>

namespace relit {
namespace {

testing::AssertionResult Contains(const std::string& text, const std::string& part) {
  if (text.find(part) != std::string::npos) return testing::AssertionSuccess();
  return testing::AssertionFailure() << "'" << part << "' not found in: " << text;
}

// The error message of `action`, "" when it does not throw.
template <typename F>
std::string ErrorOf(F action) {
  try {
    action();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

struct HullSection {
  bool enabled = true;
  double voxel_m = 0.002;
  int min_views = 3;

  static const OptionFields<HullSection>& Fields() {
    static const auto fields = OptionFields<HullSection>()
                                   .Add("enabled", &HullSection::enabled, "carve a hull")
                                   .Add("voxel_m", &HullSection::voxel_m, 0.0, 1.0, "voxel side | metres")
                                   .Add("min_views", &HullSection::min_views, 1, 100, "views that see through");
    return fields;
  }
  void Check() const { RELIT_REQUIRE(!enabled || voxel_m > 0, "voxel_m must be > 0 when enabled"); }
};

struct ProxySection {
  std::string method = "dense";
  std::vector<std::string> steps = {"a"};
  std::optional<double> offset_s;
  float gamma = 2.2f;
  std::vector<double> weights = {1.0, 0.5};
  HullSection hull;

  static const OptionFields<ProxySection>& Fields() {
    static const auto fields =
        OptionFields<ProxySection>()
            .Add("method", &ProxySection::method, {"dense", "sparse", "mesh"}, "where the proxy comes from")
            .Add("steps", &ProxySection::steps, {"a", "b"}, "steps to run")
            .Add("offset_s", &ProxySection::offset_s, -10, 10, "manual offset, s")
            .Add("gamma", &ProxySection::gamma, "display gamma")
            .Add("weights", &ProxySection::weights, "weights")
            .Section("hull", &ProxySection::hull)
            .Moved("hull_voxel_m", "hull.voxel_m");
    return fields;
  }
};

ProxySection Parse(const std::string& yaml) {
  OptionsReader reader = OptionsReader::FromString(yaml, "p.yaml");
  ProxySection options;
  ReadOptions(reader, &options);
  return options;
}

TEST(OptionFields, ReadsValuesSectionsAndKeepsDefaults) {
  const ProxySection options = Parse("method: sparse\nsteps: [b, a]\noffset_s: -0.5\nhull: {min_views: 7}\n");
  EXPECT_EQ(options.method, "sparse");
  EXPECT_EQ(options.steps, (std::vector<std::string>{"b", "a"}));
  ASSERT_TRUE(options.offset_s.has_value());
  EXPECT_EQ(*options.offset_s, -0.5);
  EXPECT_EQ(options.hull.min_views, 7);
  EXPECT_EQ(options.hull.voxel_m, 0.002);  // untouched default
  EXPECT_FALSE(Parse("{}").offset_s.has_value());
}

TEST(OptionFields, ReadErrorsNameFileLineKeyAndSuggest) {
  EXPECT_TRUE(Contains(ErrorOf([] { Parse("method: dens\n"); }),
                       "p.yaml:1:9 key 'method': 'dens' is not one of dense, sparse, mesh (did you mean 'dense'?)"));
  EXPECT_TRUE(Contains(ErrorOf([] { Parse("steps: [a, c]\n"); }), "'c' is not one of a, b"));
  EXPECT_TRUE(Contains(ErrorOf([] { Parse("hull:\n  min_views: 0\n"); }),
                       "p.yaml:2:14 key 'hull.min_views': value 0 is out of range [1, 100]"));
  EXPECT_TRUE(Contains(ErrorOf([] { Parse("offset_s: 11\n"); }), "key 'offset_s': value 11 is out of range"));
  EXPECT_TRUE(Contains(ErrorOf([] { Parse("hull: {min_veiws: 2}\n"); }),
                       "p.yaml:1: unknown key 'hull.min_veiws', did you mean 'min_views'?"));
}

TEST(OptionFields, MovedKeyIsRefusedWithItsNewName) {
  const std::string error = ErrorOf([] { Parse("method: dense\nhull_voxel_m: 0.01\n"); });
  EXPECT_TRUE(Contains(error, "p.yaml:2:15 key 'hull_voxel_m': moved to 'hull.voxel_m'")) << error;
  OptionsReader nested = OptionsReader::FromString("proxy:\n  hull_voxel_m: 0.01\n", "q.yaml");
  OptionsReader child = nested.Child("proxy");
  ProxySection options;
  EXPECT_TRUE(Contains(ErrorOf([&] { ReadOptions(child, &options); }), "moved to 'proxy.hull.voxel_m'"));
}

TEST(OptionFields, CheckOptionsChecksRangesChoicesAndAcrossFields) {
  ProxySection options;
  EXPECT_EQ(ErrorOf([&] { CheckOptions(options); }), "");
  options.hull.min_views = 0;
  EXPECT_EQ(ErrorOf([&] { CheckOptions(options, "proxy"); }),
            "proxy.hull.min_views must be in [1, 100], got 0 (views that see through)");
  options = ProxySection();
  options.method = "nope";
  EXPECT_TRUE(Contains(ErrorOf([&] { CheckOptions(options); }), "method: 'nope' is not one of dense"));
  options = ProxySection();
  options.offset_s = 20;
  EXPECT_TRUE(Contains(ErrorOf([&] { CheckOptions(options); }), "offset_s must be in [-10, 10], got 20"));
  options = ProxySection();
  options.hull.voxel_m = 0;
  EXPECT_EQ(ErrorOf([&] { CheckOptions(options); }), "hull: voxel_m must be > 0 when enabled");
  options.hull.voxel_m = std::nan("");
  EXPECT_TRUE(Contains(ErrorOf([&] { CheckOptions(options); }), "hull.voxel_m must be in [0, 1], got nan"));
}

TEST(OptionFields, ToJsonWritesEveryFieldWithSections) {
  ProxySection options = Parse("offset_s: 0.25\n");
  nlohmann::json json = OptionsToJson(options);
  EXPECT_EQ(json["method"], "dense");
  EXPECT_EQ(json["offset_s"], 0.25);
  EXPECT_EQ(json["hull"]["min_views"], 3);
  EXPECT_EQ(json["weights"], nlohmann::json({1.0, 0.5}));
  EXPECT_TRUE(OptionsToJson(ProxySection())["offset_s"].is_null());
  EXPECT_EQ(json.size(), 6u);
}

TEST(OptionFields, MarkdownListsDefaultsRangesChoicesAndMovedKeys) {
  const std::string text = OptionsMarkdown<ProxySection>("proxy.");
  EXPECT_TRUE(Contains(text, "| key | default | range | meaning |\n| --- | --- | --- | --- |\n"));
  EXPECT_TRUE(Contains(text, "| `proxy.method` | dense | dense, sparse, mesh | where the proxy comes from |\n"));
  EXPECT_TRUE(Contains(text, "| `proxy.offset_s` | unset | [-10, 10] | manual offset, s |\n"));
  EXPECT_TRUE(Contains(text, "| `proxy.gamma` | 2.2 |  | display gamma |\n"));
  EXPECT_TRUE(Contains(text, "| `proxy.steps` | [a] | a, b | steps to run |\n"));
  EXPECT_TRUE(Contains(text, "| `proxy.hull.voxel_m` | 0.002 | [0, 1] | voxel side \\| metres |\n"));
  EXPECT_TRUE(Contains(text, "`proxy.hull_voxel_m` -> `proxy.hull.voxel_m`"));
}

// A section whose optimiser keys stand beside its own (Inline), and whose
// JSON leaves out a key that does not apply (OnToJson).
struct OptimizerPart {
  double rate = 0.1;
  int batch = 2;

  static const OptionFields<OptimizerPart>& Fields() {
    static const auto fields = OptionFields<OptimizerPart>()
                                   .Add("rate", &OptimizerPart::rate, 0.0, 1.0, "step size")
                                   .Add("batch", &OptimizerPart::batch, 1, 64, "frames per step");
    return fields;
  }
  void Check() const { RELIT_REQUIRE(batch % 2 == 0, "batch must be even"); }
};

struct TrainSection {
  int steps = 10;
  std::string schedule = "none";
  double decay = 0.5;  // only with schedule: step
  OptimizerPart optimizer;

  static const OptionFields<TrainSection>& Fields() {
    static const auto fields =
        OptionFields<TrainSection>()
            .Add("steps", &TrainSection::steps, 1, 1000, "steps")
            .Add("schedule", &TrainSection::schedule, {"none", "step"}, "learning-rate schedule")
            .Add("decay", &TrainSection::decay, 0.0, 1.0, "decay per step (schedule: step)")
            .Inline(&TrainSection::optimizer)
            .OnToJson([](const TrainSection& s, nlohmann::json* json) {
              if (s.schedule == "none") json->erase("decay");
            });
    return fields;
  }
};

TEST(OptionFields, InlineKeysStandBesideTheSectionsOwn) {
  OptionsReader reader = OptionsReader::FromString("steps: 20\nrate: 0.5\nbatch: 4\n", "t.yaml");
  TrainSection options;
  ReadOptions(reader, &options);
  EXPECT_EQ(options.steps, 20);
  EXPECT_EQ(options.optimizer.rate, 0.5);
  EXPECT_EQ(options.optimizer.batch, 4);
  OptionsReader typo = OptionsReader::FromString("steps: 20\nrat: 0.5\n", "t.yaml");
  EXPECT_TRUE(Contains(ErrorOf([&] { ReadOptions(typo, &options); }), "unknown key 'rat', did you mean 'rate'?"));
  OptionsReader range = OptionsReader::FromString("batch: 100\n", "t.yaml");
  EXPECT_TRUE(Contains(ErrorOf([&] { ReadOptions(range, &options); }), "key 'batch': value 100 is out of range"));
  options.optimizer.batch = 3;
  EXPECT_EQ(ErrorOf([&] { CheckOptions(options, "train"); }), "train: batch must be even");
  EXPECT_EQ(OptionsToJson(TrainSection()),
            nlohmann::json({{"steps", 10}, {"schedule", "none"}, {"rate", 0.1}, {"batch", 2}}));
  options = TrainSection();
  options.schedule = "step";
  EXPECT_EQ(OptionsToJson(options)["decay"], 0.5);
  const std::string text = OptionsMarkdown<TrainSection>("train.");
  EXPECT_TRUE(Contains(text, "| `train.decay` | 0.5 | [0, 1] | decay per step (schedule: step) |\n"
                             "| `train.rate` | 0.1 | [0, 1] | step size |\n"));
}

TEST(OptionFields, FormatsNumbersAsTheyAreWritten) {
  using internal::FormatOptionValue;
  EXPECT_EQ(FormatOptionValue(0.0005), "0.0005");
  EXPECT_EQ(FormatOptionValue(1e-7), "1e-7");
  EXPECT_EQ(FormatOptionValue(1e-16), "1e-16");
  EXPECT_EQ(FormatOptionValue(100000.0), "100000");
  EXPECT_EQ(FormatOptionValue(0.0), "0");
  EXPECT_EQ(FormatOptionValue(-2.5), "-2.5");
  EXPECT_EQ(FormatOptionValue(std::string()), "\"\"");
  EXPECT_EQ(FormatOptionValue(std::vector<double>{0.01, 0, 0}), "[0.01, 0, 0]");
}

}  // namespace
}  // namespace relit
