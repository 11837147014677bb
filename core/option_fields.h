// Field tables for options structs: one row per option (YAML key, member,
// range or choices, one-line doc); the default is the member's initialiser
// and is written nowhere else. From the table, generic code
//   - reads a YAML section (ReadOptions: OptionsReader's file:line errors and
//     did-you-mean, range and choice checks, refusal of moved keys),
//   - checks code-built options (CheckOptions: ranges and choices, then the
//     struct's own Check(), which holds only checks across fields),
//   - writes the run record's JSON (OptionsToJson),
//   - writes the docs' reference tables (OptionsMarkdown; tools/options_doc).
// In the spirit of pbrt-v4's ParameterDictionary and COLMAP's OptionManager.
//
//   struct SyncOptions {
//     int sample_rate_hz = 16000;     // the default: here only
//     static const OptionFields<SyncOptions>& Fields();
//     void Check() const;             // optional: checks across fields only
//   };
//   RELIT_OPTION_FIELDS(SyncOptions,  // in the .cc: defines SyncOptions::Fields()
//       .Add("sample_rate_hz", &S::sample_rate_hz, 1000, 96000,
//            "both tracks are resampled to this rate"))
//
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/options.h"

namespace relit {

// One row of a docs reference table.
struct OptionDocRow {
  std::string key;           // dotted, relative to the documented section
  std::string default_text;  // as it would be written in YAML
  std::string range_text;    // "[min, max]", "a, b, c" or ""
  std::string doc;
};

namespace internal {
std::string FormatOptionValue(bool value);
std::string FormatOptionValue(int64_t value);
std::string FormatOptionValue(uint64_t value);
std::string FormatOptionValue(double value);
std::string FormatOptionValue(const std::string& value);
std::string FormatOptionValue(const std::optional<double>& value);
inline std::string FormatOptionValue(int value) { return FormatOptionValue(int64_t{value}); }
std::string FormatOptionValue(float value);
template <typename E>
std::string FormatOptionValue(const std::vector<E>& values) {
  std::string text = "[";
  for (const E& value : values) text += (text.size() > 1 ? ", " : "") + FormatOptionValue(value);
  return text + "]";
}
std::string JoinChoices(const std::vector<std::string>& choices);
// "'x' is not one of a, b (did you mean 'y'?)" when `value` is not a choice.
std::string ChoiceError(const std::string& value, const std::vector<std::string>& choices);
std::string Dotted(const std::string& context, const std::string& key);

inline nlohmann::json OptionJson(const std::optional<double>& value) {
  return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
}
template <typename T>
nlohmann::json OptionJson(const T& value) {
  return value;
}

template <typename S, typename = void>
struct HasCheck : std::false_type {};
template <typename S>
struct HasCheck<S, std::void_t<decltype(std::declval<const S&>().Check())>> : std::true_type {};
}  // namespace internal

template <typename S>
class OptionFields {
 public:
  // A value: bool, int, int64_t, uint64_t, double, float, std::string,
  // std::vector<double|int|std::string>, or std::optional<double> (absent =
  // unset, null in the JSON).
  template <typename T>
  OptionFields& Add(const char* key, T S::*member, const char* doc) {
    Field field = Value(key, member, doc);
    field.read = [key, member](OptionsReader& r, S* s) { ReadValue(r, key, &(s->*member)); };
    fields_.push_back(std::move(field));
    return *this;
  }

  // A number (or an optional number) within [min, max]: the bound of the
  // reader and of CheckOptions.
  template <typename T, typename L>
  OptionFields& Add(const char* key, T S::*member, L min_value, L max_value, const char* doc) {
    using N = typename Numeric<T>::type;
    static_assert(std::is_arithmetic_v<N> && !std::is_same_v<N, bool>, "a range needs a number");
    const N min = static_cast<N>(min_value), max = static_cast<N>(max_value);
    Field field = Value(key, member, doc);
    field.range_text = "[" + internal::FormatOptionValue(min) + ", " + internal::FormatOptionValue(max) + "]";
    field.read = [key, member, min, max](OptionsReader& r, S* s) { ReadValue(r, key, &(s->*member), min, max); };
    field.check = [key, member, min, max, doc](const S& s, const std::string& context) {
      const std::optional<N> value = s.*member;
      // Written as !(in range) so NaN is refused too.
      RELIT_REQUIRE(!value || (*value >= min && *value <= max), internal::Dotted(context, key),
                    " must be in [", internal::FormatOptionValue(min), ", ", internal::FormatOptionValue(max),
                    "], got ", internal::FormatOptionValue(value.value_or(N{})), " (", doc, ")");
    };
    fields_.push_back(std::move(field));
    return *this;
  }

  // A string, or a list of strings, out of a fixed set.
  template <typename T>
  OptionFields& Add(const char* key, T S::*member, std::vector<std::string> choices, const char* doc) {
    static_assert(std::is_same_v<T, std::string> || std::is_same_v<T, std::vector<std::string>>,
                  "choices need a string or a list of strings");
    Field field = Value(key, member, doc);
    field.range_text = internal::JoinChoices(choices);
    field.read = [key, member, choices](OptionsReader& r, S* s) {
      r.Read(key, &(s->*member));
      if (!r.Has(key)) return;
      for (const std::string& value : Values(s->*member)) {
        const std::string error = internal::ChoiceError(value, choices);
        RELIT_REQUIRE(error.empty(), r.Where(key), ": ", error);
      }
    };
    field.check = [key, member, choices, doc](const S& s, const std::string& context) {
      for (const std::string& value : Values(s.*member)) {
        const std::string error = internal::ChoiceError(value, choices);
        RELIT_REQUIRE(error.empty(), internal::Dotted(context, key), ": ", error, " (", doc, ")");
      }
    };
    fields_.push_back(std::move(field));
    return *this;
  }

  // A nested section with its own table (C::Fields()).
  template <typename C>
  OptionFields& Section(const char* key, C S::*member) {
    Field field;
    field.key = key;
    field.read = [key, member](OptionsReader& r, S* s) {
      OptionsReader child = r.Child(key);
      C::Fields().Read(child, &(s->*member));
    };
    field.check = [key, member](const S& s, const std::string& context) {
      C::Fields().Check(s.*member, internal::Dotted(context, key));
    };
    field.to_json = [member](const S& s) { return C::Fields().ToJson(s.*member); };
    field.section_rows = [key, member](const S& defaults, const std::string& prefix, DocRows* rows,
                                       MovedKeys* moved) {
      C::Fields().AppendRows(defaults.*member, prefix + key + ".", rows, moved);
    };
    fields_.push_back(std::move(field));
    return *this;
  }

  // A struct with its own table (C::Fields()) whose keys stand at this
  // level, beside S's own (e.g. relight's train: holds the optimiser's keys):
  // read, checked, written and documented as if they were S's.
  template <typename C>
  OptionFields& Inline(C S::*member) {
    Field field;
    field.inline_json = true;
    field.read = [member](OptionsReader& r, S* s) { C::Fields().ReadFields(r, &(s->*member)); };
    field.check = [member](const S& s, const std::string& context) { C::Fields().Check(s.*member, context); };
    field.to_json = [member](const S& s) { return C::Fields().ToJson(s.*member); };
    field.section_rows = [member](const S& defaults, const std::string& prefix, DocRows* rows, MovedKeys* moved) {
      C::Fields().AppendRows(defaults.*member, prefix, rows, moved);
    };
    fields_.push_back(std::move(field));
    return *this;
  }

  // A key that moved (e.g. proxy.photo_views -> proxy.photo.views): reading
  // it is an error that names the new key. Both keys are relative to S.
  OptionFields& Moved(const char* old_key, const char* new_key) {
    moved_.emplace_back(old_key, new_key);
    return *this;
  }

  // Called after the fields are read, before Finish() (rules such as "a
  // mesh alone means proxy.method: mesh").
  OptionFields& OnRead(std::function<void(OptionsReader&, S*)> hook) {
    on_read_ = std::move(hook);
    return *this;
  }

  // Called on the JSON ToJson() writes, to leave out keys that do not apply
  // or add what is not a key (run records and resume fingerprints compare
  // these JSONs, so a record keeps the keys it always had).
  OptionFields& OnToJson(std::function<void(const S&, nlohmann::json*)> hook) {
    on_to_json_ = std::move(hook);
    return *this;
  }

  void Read(OptionsReader& reader, S* options) const {
    ReadFields(reader, options);
    reader.Finish();
  }

  // Read() without the check for unknown keys (Inline's: the keys of the
  // enclosing struct stand in the same section).
  void ReadFields(OptionsReader& reader, S* options) const {
    for (const auto& [old_key, new_key] : moved_) {
      RELIT_REQUIRE(!reader.Has(old_key), reader.Where(old_key), ": moved to '",
                    internal::Dotted(reader.context(), new_key), "'");
    }
    for (const Field& field : fields_) field.read(reader, options);
    if (on_read_) on_read_(reader, options);
  }

  // Ranges and choices of every field (sections included), then S::Check().
  // Errors name the dotted key below `context` and end with the field's doc
  // (which names the command-line flag, if any).
  void Check(const S& options, const std::string& context) const {
    for (const Field& field : fields_) {
      if (field.check) field.check(options, context);
    }
    if constexpr (internal::HasCheck<S>::value) {
      if (context.empty()) return options.Check();
      try {
        options.Check();
      } catch (const Error& e) {
        Fail(context, ": ", e.what());
      }
    }
  }

  nlohmann::json ToJson(const S& options) const {
    nlohmann::json json = nlohmann::json::object();
    for (const Field& field : fields_) {
      if (field.inline_json) {
        json.update(field.to_json(options));
      } else {
        json[field.key] = field.to_json(options);
      }
    }
    if (on_to_json_) on_to_json_(options, &json);
    return json;
  }

  using DocRows = std::vector<OptionDocRow>;
  using MovedKeys = std::vector<std::pair<std::string, std::string>>;
  // The docs' rows with the defaults of `defaults`, keys below `prefix`, and
  // the moved keys (old, new).
  void AppendRows(const S& defaults, const std::string& prefix, DocRows* rows, MovedKeys* moved) const {
    for (const auto& [old_key, new_key] : moved_) moved->emplace_back(prefix + old_key, prefix + new_key);
    for (const Field& field : fields_) {
      if (field.section_rows) {
        field.section_rows(defaults, prefix, rows, moved);
      } else {
        rows->push_back({prefix + field.key, field.default_text(defaults), field.range_text, field.doc});
      }
    }
  }

 private:
  struct Field {
    std::string key, doc, range_text;
    bool inline_json = false;  // Inline: the JSON's keys go into S's
    std::function<void(OptionsReader&, S*)> read;
    std::function<void(const S&, const std::string&)> check;  // empty: nothing to check
    std::function<nlohmann::json(const S&)> to_json;
    std::function<std::string(const S&)> default_text;  // values
    std::function<void(const S&, const std::string&, DocRows*, MovedKeys*)> section_rows;  // sections
  };

  template <typename T>
  struct Numeric {
    using type = T;
  };
  template <typename T>
  struct Numeric<std::optional<T>> {
    using type = T;
  };

  template <typename T>
  static Field Value(const char* key, T S::*member, const char* doc) {
    Field field;
    field.key = key;
    field.doc = doc;
    field.to_json = [member](const S& s) { return internal::OptionJson(s.*member); };
    field.default_text = [member](const S& s) { return internal::FormatOptionValue(s.*member); };
    return field;
  }

  template <typename T>
  static void ReadValue(OptionsReader& r, const char* key, T* value) {
    r.Read(key, value);
  }
  template <typename T, typename N>
  static void ReadValue(OptionsReader& r, const char* key, T* value, N min, N max) {
    r.ReadRange(key, value, min, max);
  }
  static void ReadValue(OptionsReader& r, const char* key, std::optional<double>* value) {
    if (!r.Has(key)) return r.Ignore(key);
    double number = 0;
    r.Read(key, &number);
    *value = number;
  }
  static void ReadValue(OptionsReader& r, const char* key, std::optional<double>* value, double min, double max) {
    if (!r.Has(key)) return r.Ignore(key);
    double number = 0;
    r.ReadRange(key, &number, min, max);
    *value = number;
  }

  static std::vector<std::string> Values(const std::string& value) { return {value}; }
  static const std::vector<std::string>& Values(const std::vector<std::string>& values) { return values; }

  std::vector<Field> fields_;
  MovedKeys moved_;
  std::function<void(OptionsReader&, S*)> on_read_;
  std::function<void(const S&, nlohmann::json*)> on_to_json_;
};

// Defines Struct::Fields(), declared in Struct as
//   static const OptionFields<Struct>& Fields();
// as the table its rows (.Add(...), .Section(...), .Moved(...), ...) build,
// once, on first use. In the rows, S names Struct.
#define RELIT_OPTION_FIELDS(Struct, ...)                                                    \
  const ::relit::OptionFields<Struct>& Struct::Fields() {                                   \
    using S = Struct;                                                                       \
    static const ::relit::OptionFields<S> fields = ::relit::OptionFields<S>() __VA_ARGS__;  \
    return fields;                                                                          \
  }

// The generic operations, for a struct with a static Fields().
template <typename S>
void ReadOptions(OptionsReader& reader, S* options) {
  S::Fields().Read(reader, options);
}

// A command line's options: the defaults, then the --config file when one
// is given ("" = none). Flags go on top, then CheckOptions().
template <typename S>
S ReadOptionsFile(const std::string& config) {
  S options;
  if (config.empty()) return options;
  OptionsReader reader = OptionsReader::FromFile(config);
  ReadOptions(reader, &options);
  return options;
}

template <typename S>
void CheckOptions(const S& options, const std::string& context = "") {
  S::Fields().Check(options, context);
}

template <typename S>
nlohmann::json OptionsToJson(const S& options) {
  return S::Fields().ToJson(options);
}

// The docs' reference table of S (defaults from `defaults`, S{} unless
// given): a Markdown table "| key | default | range | meaning |", keys below
// `prefix`, then a line listing the moved keys, if any.
std::string OptionsMarkdownTable(const std::vector<OptionDocRow>& rows,
                                 const std::vector<std::pair<std::string, std::string>>& moved);
template <typename S>
std::string OptionsMarkdown(const S& defaults, const std::string& prefix = "") {
  std::vector<OptionDocRow> rows;
  std::vector<std::pair<std::string, std::string>> moved;
  S::Fields().AppendRows(defaults, prefix, &rows, &moved);
  return OptionsMarkdownTable(rows, moved);
}
template <typename S>
std::string OptionsMarkdown(const std::string& prefix = "") {
  return OptionsMarkdown(S{}, prefix);
}

}  // namespace relit
