// Options from YAML files, mapped onto plain structs.
//
// Stage options are described by field tables (core/option_fields.h), which
// read through this reader. The hand-written pattern below is what relight's
// structs still use (to be converted):
//
//   struct RenderOptions {
//     int samples = 64;            // defaults live here, nowhere else
//     double exposure = 0.0;
//     DenoiseOptions denoise;      // nested component
//
//     void Read(OptionsReader& reader) {
//       reader.ReadRange("samples", &samples, 1, 1 << 16);
//       reader.Read("exposure", &exposure);
//       OptionsReader child = reader.Child("denoise");
//       denoise.Read(child);
//       reader.Finish();           // unknown keys (typos) become errors
//     }
//     void Check() const;          // invariants, also for code-built options
//     nlohmann::json ToJson() const;  // for the run record
//   };
//
// An absent key keeps the default, so an empty or missing section means "all
// defaults". A present key must convert, otherwise the error names the file,
// the 1-based line and column, the dotted key and the offending text.
// Finish() also checks nested sections opened with Child(), so a typo deep in
// the file is caught even if a nested Read forgot to call Finish(); calling
// Finish() at every level is still the norm (and harmless).
#pragma once

#include <cstdint>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace relit {

namespace internal {
template <typename T>
constexpr bool kIsOptionType =
    std::is_same_v<T, bool> || std::is_same_v<T, int> || std::is_same_v<T, int64_t> ||
    std::is_same_v<T, uint64_t> || std::is_same_v<T, double> || std::is_same_v<T, float> ||
    std::is_same_v<T, std::string> || std::is_same_v<T, std::vector<double>> ||
    std::is_same_v<T, std::vector<int>> || std::is_same_v<T, std::vector<std::string>>;

// Optimal string alignment distance (Levenshtein plus adjacent swaps), used
// for "did you mean" suggestions.
int EditDistance(const std::string& a, const std::string& b);
}  // namespace internal

// Limits of the one YAML reader (LoadYaml): YAML aliases are expanded by
// every consumer that walks the tree, so a few lines of nested aliases ("billion
// laughs") would otherwise exhaust memory.
inline constexpr int kMaxYamlAliases = 1000;
inline constexpr int64_t kMaxYamlExpandedNodes = 100000;
inline constexpr int kMaxYamlDepth = 64;

// Parses YAML text (the first document). A syntax error, more than
// kMaxYamlAliases aliases, more than kMaxYamlExpandedNodes nodes once aliases
// are expanded, or nesting deeper than kMaxYamlDepth is a relit::Error
// "file:line:col: ..." that says what to change. Every YAML file relit reads
// goes through here.
YAML::Node LoadYaml(const std::string& text, const std::string& file);

class OptionsReader {
 public:
  // `node` must be a mapping or Null (all defaults). `file` is shown in
  // errors; `context` is the dotted path of this mapping ("" at the root).
  OptionsReader(const YAML::Node& node, std::string file, std::string context = "");

  // Loads a YAML file. A missing file or a syntax error is a relit::Error
  // with file:line:col. An empty file gives an all-defaults reader.
  static OptionsReader FromFile(const std::string& path);
  // Parses YAML text; `file` is only used in messages.
  static OptionsReader FromString(const std::string& text, const std::string& file = "<string>");

  // If `key` is present, converts it into *value (wrong type -> relit::Error
  // "file:line:col: key 'ctx.key': expected <type>, got '<text>'"); if absent,
  // leaves *value unchanged. Supported T: bool, int, int64_t, uint64_t,
  // double, float, std::string, std::vector<double|int|std::string>.
  // Integers are decimal only (YAML's 010 would otherwise be octal).
  template <typename T>
  void Read(const std::string& key, T* value);

  // Read() plus a check that min <= value <= max (for numbers).
  template <typename T>
  void ReadRange(const std::string& key, T* value, T min, T max);

  // The nested mapping at `key`; a Null reader (all defaults) when absent.
  OptionsReader Child(const std::string& key);

  // Marks `key` as known without reading it (e.g. a section that only applies
  // to another mode). It is also listed among the known keys.
  void Ignore(const std::string& key);

  // True when `key` is present. A pure query: the key still has to be read
  // (or ignored) to pass Finish().
  bool Has(const std::string& key) const;

  // Throws relit::Error for the first key (in file order) of this mapping or
  // of a nested Child() mapping that no Read/Child/Ignore/Has asked for:
  // "file:line: unknown key 'ctx.key', did you mean 'x'? (known keys: a, b)".
  void Finish();

  // "file:line:col key 'ctx.key'" (just "file key 'ctx.key'" when absent),
  // for errors raised by the caller about a value it read.
  std::string Where(const std::string& key) const;

  const std::string& file() const { return file_; }
  const std::string& context() const { return context_; }
  bool IsNull() const { return !node_.IsDefined() || node_.IsNull(); }

 private:
  // Known keys per mapping (by context) and the contexts opened by Child(),
  // shared by a reader and all its children.
  struct Tracker {
    std::set<std::pair<std::string, std::string>> known;  // (context, key)
    std::set<std::string> children;                       // child contexts
  };

  OptionsReader(const YAML::Node& node, std::string file, std::string context,
                std::shared_ptr<Tracker> tracker);

  std::string Qualified(const std::string& key) const;
  // Finds `key` in this mapping; false when absent. *position is
  // "file:line:col" of the value (of the key when the value is empty).
  bool Find(const std::string& key, YAML::Node* value, std::string* position) const;
  // "file:line:col" of a node, or just "file" when it has no position.
  std::string Position(const YAML::Node& node) const;
  [[noreturn]] void FailType(const std::string& position, const std::string& qualified,
                             const YAML::Node& node, const char* expected) const;
  [[noreturn]] void FailRange(const std::string& key, const std::string& value,
                              const std::string& min, const std::string& max) const;

  // Conversions; they throw on mismatch. T: bool, int, int64_t, uint64_t,
  // double or float (instantiated in options.cc).
  using Pos = std::string;
  template <typename T>
  void Convert(const std::string& qualified, const YAML::Node& node, const Pos& position, T* value) const;
  void Convert(const std::string& qualified, const YAML::Node& node, const Pos& position,
               std::string* value) const;
  template <typename E>
  void Convert(const std::string& qualified, const YAML::Node& node, const Pos& position,
               std::vector<E>* value) const;

  YAML::Node node_;
  std::string file_;
  std::string context_;
  std::shared_ptr<Tracker> tracker_;
};

// ---- implementation of the templates ----

template <typename T>
void OptionsReader::Read(const std::string& key, T* value) {
  static_assert(internal::kIsOptionType<T>, "unsupported option type, see OptionsReader::Read");
  Ignore(key);  // known from now on, present or not
  YAML::Node node;
  std::string position;
  if (!Find(key, &node, &position)) return;
  T converted{};
  Convert(Qualified(key), node, position, &converted);
  *value = std::move(converted);
}

template <typename T>
void OptionsReader::ReadRange(const std::string& key, T* value, T min, T max) {
  static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>,
                "ReadRange needs a numeric option");
  Read(key, value);
  // Written as !(in range) so NaN is rejected too.
  if (!(*value >= min && *value <= max)) {
    auto text = [](T v) {
      std::ostringstream stream;
      stream << v;
      return stream.str();
    };
    FailRange(key, text(*value), text(min), text(max));
  }
}

}  // namespace relit
