#include "core/options.h"

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "core/error.h"

namespace relit {
namespace {

testing::AssertionResult Contains(const std::string& text, const std::string& part) {
  if (text.find(part) != std::string::npos) return testing::AssertionSuccess();
  return testing::AssertionFailure() << "'" << part << "' not found in: " << text;
}

// The documented pattern, as a component would write it.
struct DenoiseOptions {
  bool enabled = true;
  double strength = 0.5;

  // Deliberately no Finish(): the parent's Finish() must still catch typos.
  void Read(OptionsReader& reader) {
    reader.Read("enabled", &enabled);
    reader.ReadRange("strength", &strength, 0.0, 1.0);
  }
};

struct ExampleOptions {
  int samples = 64;
  double exposure = 0.0;
  float gamma = 2.2f;
  int64_t budget = -1;
  uint64_t seed = 7;
  std::string name = "default";
  std::vector<double> weights = {1.0, 2.0};
  std::vector<int> frames;
  std::vector<std::string> tags;
  DenoiseOptions denoise;

  void Read(OptionsReader& reader) {
    reader.ReadRange("samples", &samples, 1, 4096);
    reader.ReadRange("exposure", &exposure, -10.0, 10.0);
    reader.Read("gamma", &gamma);
    reader.Read("budget", &budget);
    reader.Read("seed", &seed);
    reader.Read("name", &name);
    reader.Read("weights", &weights);
    reader.Read("frames", &frames);
    reader.Read("tags", &tags);
    OptionsReader child = reader.Child("denoise");
    denoise.Read(child);
    RELIT_REQUIRE(frames.size() <= 3, reader.Where("frames"), ": at most 3 frames");
    reader.Finish();
  }
  nlohmann::json ToJson() const {
    return {{"samples", samples}, {"exposure", exposure}, {"name", name},
            {"denoise", {{"enabled", denoise.enabled}, {"strength", denoise.strength}}}};
  }
};

ExampleOptions Parse(const std::string& yaml) {
  OptionsReader reader = OptionsReader::FromString(yaml, "cfg.yaml");
  ExampleOptions options;
  options.Read(reader);
  return options;
}

// The relit::Error message of parsing `yaml`.
std::string ParseError(const std::string& yaml) {
  try {
    Parse(yaml);
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an error for:\n" << yaml;
  return "";
}

TEST(Options, EmptyInputKeepsDefaults) {
  for (const std::string yaml : {"", "# only a comment\n", "denoise:\n"}) {
    const ExampleOptions options = Parse(yaml);
    EXPECT_EQ(options.samples, 64);
    EXPECT_EQ(options.name, "default");
    EXPECT_EQ(options.weights, std::vector<double>({1.0, 2.0}));
    EXPECT_TRUE(options.denoise.enabled);
  }
  OptionsReader null_reader(YAML::Node(), "none");
  EXPECT_TRUE(null_reader.IsNull());
  int value = 3;
  null_reader.Read("x", &value);
  EXPECT_EQ(value, 3);
  null_reader.Finish();
}

TEST(Options, ReadsEveryType) {
  const ExampleOptions options = Parse(
      "samples: 128\n"
      "exposure: -1.5e-1\n"
      "gamma: 1.8\n"
      "budget: 9000000000\n"
      "seed: 18446744073709551615\n"
      "name: studio lights\n"
      "weights: [0.5, 1, 2e3]\n"
      "frames: [1, +2, 010]\n"
      "tags: [a, 'b c']\n"
      "denoise:\n"
      "  enabled: false\n"
      "  strength: 0.25\n");
  EXPECT_EQ(options.samples, 128);
  EXPECT_DOUBLE_EQ(options.exposure, -0.15);
  EXPECT_FLOAT_EQ(options.gamma, 1.8f);
  EXPECT_EQ(options.budget, 9000000000LL);
  EXPECT_EQ(options.seed, 18446744073709551615ULL);
  EXPECT_EQ(options.name, "studio lights");
  EXPECT_EQ(options.weights, std::vector<double>({0.5, 1.0, 2000.0}));
  EXPECT_EQ(options.frames, std::vector<int>({1, 2, 10}));  // decimal, not octal
  EXPECT_EQ(options.tags, std::vector<std::string>({"a", "b c"}));
  EXPECT_FALSE(options.denoise.enabled);
  EXPECT_DOUBLE_EQ(options.denoise.strength, 0.25);
}

TEST(Options, UnknownKeyFromFileNamesFileLineKeyAndSuggestion) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("relit_options_" + std::to_string(getpid()) + ".yaml")).string();
  std::ofstream(path) << "# render settings\nexposure: 1\nsampels: 12\n";
  OptionsReader reader = OptionsReader::FromFile(path);
  ExampleOptions options;
  std::string message;
  try {
    options.Read(reader);
  } catch (const Error& e) {
    message = e.what();
  }
  std::filesystem::remove(path);
  EXPECT_TRUE(Contains(message, path + ":3: unknown key 'sampels'")) << message;
  EXPECT_TRUE(Contains(message, "did you mean 'samples'?"));
  EXPECT_TRUE(Contains(message, "known keys: budget, denoise, exposure, frames, gamma, name, "
                                "samples, seed, tags, weights"));
}

TEST(Options, UnknownNestedKeyIsCaughtByParentFinish) {
  const std::string message = ParseError("samples: 3\ndenoise:\n  strenght: 0.2\n");
  EXPECT_TRUE(Contains(message, "cfg.yaml:3: unknown key 'denoise.strenght', did you mean "
                                "'strength'? (known keys: enabled, strength)"));
}

TEST(Options, UnknownKeyWithoutCloseMatchAndSeveralUnknown) {
  const std::string message = ParseError("zzz: 1\nsamples: 2\nqqq: 3\n");
  EXPECT_TRUE(Contains(message, "cfg.yaml:1: unknown key 'zzz' (known keys:"));
  EXPECT_FALSE(Contains(message, "did you mean"));
  EXPECT_TRUE(Contains(message, "also unknown: qqq"));
}

TEST(Options, WrongTypeNamesPositionKeyAndText) {
  EXPECT_TRUE(Contains(ParseError("name: x\nsamples: many\n"),
                       "cfg.yaml:2:10: key 'samples': expected an integer (32-bit), got 'many'"));
  EXPECT_TRUE(Contains(ParseError("samples: 1.5\n"), "got '1.5'"));
  EXPECT_TRUE(Contains(ParseError("samples: 3000000000\n"), "expected an integer"));
  EXPECT_TRUE(Contains(ParseError("seed: -1\n"), "expected a non-negative integer, got '-1'"));
  EXPECT_TRUE(Contains(ParseError("exposure: [1]\n"), "expected a number, got a list"));
  EXPECT_TRUE(Contains(ParseError("name: {a: 1}\n"), "expected a string, got a mapping"));
  EXPECT_TRUE(Contains(ParseError("weights: 3\n"), "expected a list of numbers, got '3'"));
  EXPECT_TRUE(Contains(ParseError("denoise:\n  enabled: maybe\n"),
                       "cfg.yaml:2:12: key 'denoise.enabled': expected a boolean"));
  EXPECT_TRUE(Contains(ParseError("frames: [1, 2, x]\n"),
                       "cfg.yaml:1:16: key 'frames[2]': expected an integer (32-bit), got 'x'"));
  // An empty value points at its key, not at the next line.
  EXPECT_TRUE(Contains(ParseError("samples:\nname: x\n"),
                       "cfg.yaml:1:1: key 'samples': expected an integer (32-bit), got an empty"));
  EXPECT_TRUE(Contains(ParseError("denoise: 3\n"),
                       "key 'denoise': expected a mapping of options, got '3'"));
}

TEST(Options, RangeError) {
  EXPECT_TRUE(Contains(ParseError("\nexposure: 50\n"),
                       "cfg.yaml:2:11 key 'exposure': value 50 is out of range [-10, 10]"));
  EXPECT_TRUE(Contains(ParseError("exposure: .nan\n"), "out of range"));
  EXPECT_TRUE(Contains(ParseError("denoise: {strength: 2}\n"),
                       "key 'denoise.strength': value 2 is out of range [0, 1]"));
  EXPECT_NO_THROW(Parse("exposure: 10\nsamples: 1\n"));  // bounds are inclusive
}

TEST(Options, WhereForCustomChecks) {
  EXPECT_TRUE(Contains(ParseError("frames: [1, 2, 3, 4]\n"),
                       "cfg.yaml:1:9 key 'frames': at most 3 frames"));
  OptionsReader reader = OptionsReader::FromString("a:\n  b: 1\n", "f.yaml");
  OptionsReader child = reader.Child("a");
  EXPECT_EQ(child.Where("b"), "f.yaml:2:6 key 'a.b'");
  EXPECT_EQ(child.Where("c"), "f.yaml key 'a.c'");
}

TEST(Options, HasIsAQueryAndIgnoreMarksKnown) {
  OptionsReader reader = OptionsReader::FromString("legacy: 1\nother_mode: {x: 1}\n", "f.yaml");
  EXPECT_TRUE(reader.Has("legacy"));
  EXPECT_FALSE(reader.Has("absent"));
  reader.Ignore("other_mode");
  EXPECT_THROW(reader.Finish(), Error);  // "legacy" was only queried
  reader.Ignore("legacy");
  EXPECT_NO_THROW(reader.Finish());
}

TEST(Options, SyntaxAndStructureErrors) {
  try {
    OptionsReader::FromString("a: [1, 2\nb: 3\n", "bad.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_TRUE(Contains(e.what(), "bad.yaml:2:"));
    EXPECT_TRUE(Contains(e.what(), "YAML syntax error"));
  }
  try {
    OptionsReader::FromString("- a\n- b\n", "list.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_TRUE(Contains(e.what(), "list.yaml:1:1: the top level must be a mapping"));
  }
  EXPECT_TRUE(Contains(ParseError("samples: 1\nsamples: 2\n"),
                       "cfg.yaml:2: duplicate key 'samples' (first given on line 1)"));
  try {
    OptionsReader::FromFile("/nonexistent/relit.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_TRUE(Contains(e.what(), "options file /nonexistent/relit.yaml does not exist"));
  }
}

// Hostile YAML (docs/refusals.md): alias bombs at any depth, deep nesting
// and tab indentation are refused with a message that says what to change;
// a few legitimate aliases still load.
TEST(Options, YamlLimitsRefuseAliasBombsDeepNestingAndTabs) {
  auto error_of = [](const std::string& text) {
    try {
      LoadYaml(text, "bomb.yaml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  // Nine levels of nine aliases, inside a nested section.
  std::string bomb = "relight:\n  cues:\n    a: &a [x, x, x, x, x, x, x, x, x]\n";
  for (char level = 'b'; level <= 'i'; ++level) {
    const std::string prev(1, static_cast<char>(level - 1));
    bomb += "    " + std::string(1, level) + ": &" + std::string(1, level) + " [";
    for (int i = 0; i < 9; ++i) bomb += (i ? ", *" : "*") + prev;
    bomb += "]\n";
  }
  EXPECT_TRUE(Contains(error_of(bomb), "bomb.yaml:"));
  EXPECT_TRUE(Contains(error_of(bomb), "once its aliases"));
  std::string many = "a: &a 1\nb: [";
  for (int i = 0; i <= kMaxYamlAliases; ++i) many += (i ? ", *a" : "*a");
  EXPECT_TRUE(Contains(error_of(many + "]\n"), "aliases"));
  std::string deep;
  for (int i = 0; i < 2000; ++i) deep += "{a: ";
  deep += "1" + std::string(2000, '}') + "\n";
  EXPECT_TRUE(Contains(error_of(deep), "nested deeper than"));
  EXPECT_TRUE(Contains(error_of("a:\n\tb: 1\n"), "bomb.yaml:2: YAML syntax error: a tab in the indentation"));
  // Legitimate anchors still work.
  const YAML::Node ok = LoadYaml("base: &b {x: 1}\nother: *b\n", "ok.yaml");
  EXPECT_EQ(ok["other"]["x"].as<int>(), 1);
}

TEST(Options, EditDistance) {
  EXPECT_EQ(internal::EditDistance("samples", "samples"), 0);
  EXPECT_EQ(internal::EditDistance("sampels", "samples"), 1);  // swap counts once
  EXPECT_EQ(internal::EditDistance("smples", "samples"), 1);
  EXPECT_EQ(internal::EditDistance("", "abc"), 3);
  EXPECT_EQ(internal::EditDistance("kitten", "sitting"), 3);
}

}  // namespace
}  // namespace relit
