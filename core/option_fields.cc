#include "core/option_fields.h"

#include <charconv>
#include <cmath>
#include <limits>

namespace relit {

namespace internal {

std::string FormatOptionValue(bool value) { return value ? "true" : "false"; }

std::string FormatOptionValue(int64_t value) { return std::to_string(value); }

std::string FormatOptionValue(uint64_t value) { return std::to_string(value); }

namespace {

// Shortest text that reads back the same: fixed notation in [1e-4, 1e7),
// scientific with a plain exponent ("1e-7") outside.
template <typename T>
std::string FormatNumber(T value) {
  if (std::isnan(value)) return "nan";
  if (!std::isfinite(value)) return value > 0 ? "inf" : "-inf";
  char text[64];
  const double magnitude = std::abs(value);
  const bool scientific = magnitude != 0 && (magnitude < 1e-4 || magnitude >= 1e7);
  const auto format = scientific ? std::chars_format::scientific : std::chars_format::fixed;
  const auto result = std::to_chars(text, text + sizeof(text), value, format);
  std::string out(text, result.ptr);
  const size_t e = out.find('e');
  if (e == std::string::npos) return out;
  std::string exponent = out.substr(e + 1);
  const bool negative = exponent[0] == '-';
  exponent = exponent.substr(1);
  while (exponent.size() > 1 && exponent[0] == '0') exponent.erase(0, 1);
  return out.substr(0, e) + "e" + (negative ? "-" : "") + exponent;
}

}  // namespace

std::string FormatOptionValue(double value) { return FormatNumber(value); }

std::string FormatOptionValue(float value) { return FormatNumber(value); }

std::string FormatOptionValue(const std::string& value) { return value.empty() ? "\"\"" : value; }

std::string FormatOptionValue(const std::optional<double>& value) {
  return value ? FormatOptionValue(*value) : "unset";
}

std::string Dotted(const std::string& context, const std::string& key) {
  return context.empty() ? key : context + "." + key;
}

}  // namespace internal

namespace {

// Table cells must not contain a bare '|'.
std::string Cell(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '|') out += '\\';
    out += c;
  }
  return out;
}

}  // namespace

std::string OptionsMarkdownTable(const std::vector<OptionDocRow>& rows,
                                 const std::vector<std::pair<std::string, std::string>>& moved) {
  std::string text = "| key | default | range | meaning |\n| --- | --- | --- | --- |\n";
  for (const OptionDocRow& row : rows) {
    text += "| `" + row.key + "` | " + Cell(row.default_text) + " | " + Cell(row.range_text) + " | " +
            Cell(row.doc) + " |\n";
  }
  if (!moved.empty()) {
    text += "\nMoved keys (an error that names the new key):";
    for (size_t i = 0; i < moved.size(); ++i) {
      text += std::string(i == 0 ? " " : ", ") + "`" + moved[i].first + "` -> `" + moved[i].second + "`";
    }
    text += ".\n";
  }
  return text;
}

}  // namespace relit
