#include "core/options.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <utility>

#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/eventhandler.h>

#include "core/error.h"
#include "core/option_fields.h"

namespace relit {

namespace internal {

int EditDistance(const std::string& a, const std::string& b) {
  const size_t n = a.size(), m = b.size();
  std::vector<std::vector<int>> d(n + 1, std::vector<int>(m + 1));
  for (size_t i = 0; i <= n; ++i) d[i][0] = static_cast<int>(i);
  for (size_t j = 0; j <= m; ++j) d[0][j] = static_cast<int>(j);
  for (size_t i = 1; i <= n; ++i) {
    for (size_t j = 1; j <= m; ++j) {
      const int cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[n][m];
}

}  // namespace internal

namespace {

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

// "'text'" for scalars, a word for everything else.
std::string Describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Scalar: return "'" + node.Scalar() + "'";
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Map: return "a mapping";
    default: return "an empty value";
  }
}

// The closest known key, or "" when none is close enough to be a typo.
std::string Suggest(const std::string& key, const std::vector<std::string>& known) {
  std::string best;
  int best_distance = std::numeric_limits<int>::max();
  for (const std::string& candidate : known) {
    const int distance = Lower(key) == Lower(candidate)
                             ? 0
                             : internal::EditDistance(key, candidate);
    if (distance < best_distance) {
      best_distance = distance;
      best = candidate;
    }
  }
  const int allowed = std::max<int>(1, static_cast<int>(key.size()) / 3);
  return best_distance <= allowed ? best : "";
}

// Decimal integers only: yaml-cpp would read "010" as octal and "0x10" as hex.
template <typename T>
bool ParseInteger(const std::string& text, T* value) {
  const char* begin = text.data();
  const char* end = begin + text.size();
  if (begin != end && *begin == '+') ++begin;
  if (begin == end || (begin != text.data() && *begin == '-')) return false;
  const auto result = std::from_chars(begin, end, *value, 10);
  return result.ec == std::errc() && result.ptr == end;
}

std::string MarkText(const std::string& file, const YAML::Mark& mark) {
  if (mark.is_null()) return file;
  return file + ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1);
}

// Counts the nodes a YAML document expands to (aliases count as the whole
// node they refer to) while the parser reads it, and stops it at the limits.
class LimitHandler : public YAML::EventHandler {
 public:
  explicit LimitHandler(const std::string& file) : file_(file) {}

  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t anchor) override { Leaf(mark, anchor, 1); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t anchor) override {
    if (++aliases_ > kMaxYamlAliases) {
      Fail(MarkText(file_, mark), ": more than ", kMaxYamlAliases,
           " YAML aliases (*name): write the values out instead of referring to anchors");
    }
    const auto it = sizes_.find(anchor);
    Leaf(mark, 0, it == sizes_.end() ? 1 : it->second);
  }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor,
                const std::string&) override {
    Leaf(mark, anchor, 1);
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor,
                       YAML::EmitterStyle::value) override {
    Open(mark, anchor);
  }
  void OnSequenceEnd() override { Close(); }
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor,
                  YAML::EmitterStyle::value) override {
    Open(mark, anchor);
  }
  void OnMapEnd() override { Close(); }

 private:
  struct Frame {
    YAML::anchor_t anchor;
    int64_t size;
    YAML::Mark mark;
  };
  void Open(const YAML::Mark& mark, YAML::anchor_t anchor) {
    if (static_cast<int>(stack_.size()) >= kMaxYamlDepth) {
      Fail(MarkText(file_, mark), ": YAML nested deeper than ", kMaxYamlDepth,
           " levels: relit's option files are a few levels deep; check the indentation");
    }
    stack_.push_back({anchor, 1, mark});
  }
  void Close() {
    const Frame frame = stack_.back();
    stack_.pop_back();
    Leaf(frame.mark, frame.anchor, frame.size);
  }
  void Leaf(const YAML::Mark& mark, YAML::anchor_t anchor, int64_t size) {
    if (anchor != 0) sizes_[anchor] = size;
    int64_t& total = stack_.empty() ? total_ : stack_.back().size;
    total = std::min<int64_t>(total + size, kMaxYamlExpandedNodes + 1);
    if (total > kMaxYamlExpandedNodes) {
      Fail(MarkText(file_, mark), ": the YAML expands to more than ", kMaxYamlExpandedNodes,
           " values once its aliases (*name) are replaced by their anchors (&name): write the "
           "values out, without nested aliases");
    }
  }

  const std::string& file_;
  std::map<YAML::anchor_t, int64_t> sizes_;
  std::vector<Frame> stack_;
  int64_t total_ = 0;
  int aliases_ = 0;
};

// "file:line:col: YAML syntax error: msg", naming a tab in the indentation
// (YAML indents with spaces only) when there is one.
[[noreturn]] void FailSyntax(const std::string& text, const std::string& file,
                             const YAML::ParserException& e) {
  std::istringstream lines(text);
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    const size_t content = line.find_first_not_of(" \t");
    if (content == std::string::npos || line[content] == '#') continue;
    if (line.find('\t') < content) {
      Fail(file, ":", number, ": YAML syntax error: a tab in the indentation; YAML indents with "
           "spaces only, replace the tabs with spaces");
    }
  }
  std::string message = e.msg;
  if (message.rfind(YAML::ErrorMsg::BAD_FILE, 0) == 0 || message.empty()) {
    message = "cannot be parsed (check its indentation and quotes)";
  }
  Fail(MarkText(file, e.mark), ": YAML syntax error: ", message);
}

}  // namespace

YAML::Node LoadYaml(const std::string& text, const std::string& file) {
  try {
    std::istringstream stream(text);
    YAML::Parser parser(stream);
    LimitHandler limits(file);
    parser.HandleNextDocument(limits);  // only the first document is loaded below
    return YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    FailSyntax(text, file, e);
  }
}

OptionsReader::OptionsReader(const YAML::Node& node, std::string file, std::string context)
    : OptionsReader(node, std::move(file), std::move(context), std::make_shared<Tracker>()) {}

OptionsReader::OptionsReader(const YAML::Node& node, std::string file, std::string context,
                             std::shared_ptr<Tracker> tracker)
    : node_(node), file_(std::move(file)), context_(std::move(context)),
      tracker_(std::move(tracker)) {
  if (!IsNull() && !node_.IsMap()) {
    Fail(Position(node_), ": ", context_.empty() ? "the top level" : "'" + context_ + "'",
         " must be a mapping of options (key: value), got ", Describe(node_));
  }
}

OptionsReader OptionsReader::FromString(const std::string& text, const std::string& file) {
  return OptionsReader(LoadYaml(text, file), file);
}

OptionsReader OptionsReader::FromFile(const std::string& path) {
  std::error_code ec;
  RELIT_REQUIRE(std::filesystem::is_regular_file(path, ec), "options file ", path,
                " does not exist");
  std::ifstream in(path, std::ios::binary);
  RELIT_REQUIRE(in, "cannot read options file ", path, ": check its permissions");
  std::ostringstream text;
  text << in.rdbuf();
  return OptionsReader(LoadYaml(text.str(), path), path);
}

std::string OptionsReader::Qualified(const std::string& key) const {
  return context_.empty() ? key : context_ + "." + key;
}

std::string OptionsReader::Position(const YAML::Node& node) const {
  const YAML::Mark mark = node.Mark();
  if (mark.is_null()) return file_;
  return file_ + ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1);
}

bool OptionsReader::Find(const std::string& key, YAML::Node* value,
                         std::string* position) const {
  if (IsNull()) return false;
  for (const auto& entry : node_) {
    if (!entry.first.IsScalar() || entry.first.Scalar() != key) continue;
    *value = entry.second;
    // yaml-cpp places an empty value ("key:") at the start of the next line,
    // so point at the key instead.
    *position = Position(entry.second.IsNull() ? entry.first : entry.second);
    return true;
  }
  return false;
}

void OptionsReader::Ignore(const std::string& key) { tracker_->known.emplace(context_, key); }

bool OptionsReader::Has(const std::string& key) const {
  YAML::Node value;
  std::string position;
  return Find(key, &value, &position);
}

OptionsReader OptionsReader::Child(const std::string& key) {
  Ignore(key);
  const std::string qualified = Qualified(key);
  tracker_->children.insert(qualified);
  YAML::Node value;
  std::string position;
  if (!Find(key, &value, &position)) value = YAML::Node();
  if (!value.IsNull() && !value.IsMap()) {
    Fail(position, ": key '", qualified, "': expected a mapping of options, got ",
         Describe(value));
  }
  return OptionsReader(value, file_, qualified, tracker_);
}

std::string OptionsReader::Where(const std::string& key) const {
  YAML::Node value;
  std::string position;
  if (!Find(key, &value, &position)) position = file_;
  return position + " key '" + Qualified(key) + "'";
}

void OptionsReader::Finish() {
  struct Unknown {
    int pos;
    std::string position;
    std::string context;
    std::string key;
  };
  std::vector<Unknown> unknown;
  std::vector<std::string> duplicate_errors;

  // Walks this mapping and the Child() mappings below it.
  auto walk = [&](const auto& self, const YAML::Node& node, const std::string& context) -> void {
    if (!node.IsMap()) return;
    std::map<std::string, int> first_line;
    for (const auto& entry : node) {
      const std::string key = entry.first.IsScalar() ? entry.first.Scalar() : "<complex key>";
      const YAML::Mark mark = entry.first.Mark();
      const std::string qualified = context.empty() ? key : context + "." + key;
      const std::string position = file_ + ":" + std::to_string(mark.line + 1);
      const auto [it, inserted] = first_line.emplace(key, mark.line + 1);
      if (!inserted) {
        duplicate_errors.push_back(position + ": duplicate key '" + qualified +
                                   "' (first given on line " + std::to_string(it->second) + ")");
      }
      if (tracker_->known.count({context, key}) == 0) {
        unknown.push_back({mark.pos, position, context, key});
      } else if (tracker_->children.count(qualified) != 0) {
        self(self, entry.second, qualified);
      }
    }
  };
  if (!IsNull()) walk(walk, node_, context_);

  if (!duplicate_errors.empty()) throw Error(duplicate_errors.front());
  if (unknown.empty()) return;
  std::sort(unknown.begin(), unknown.end(),
            [](const Unknown& a, const Unknown& b) { return a.pos < b.pos; });
  const Unknown& first = unknown.front();
  std::vector<std::string> known;
  for (const auto& [context, key] : tracker_->known) {
    if (context == first.context) known.push_back(key);
  }
  std::string message = first.position + ": unknown key '" +
                        (first.context.empty() ? first.key : first.context + "." + first.key) +
                        "'";
  const std::string suggestion = Suggest(first.key, known);
  if (!suggestion.empty()) message += ", did you mean '" + suggestion + "'?";
  message += known.empty() ? " (this section takes no options)"
                           : " (known keys: " + internal::JoinChoices(known) + ")";
  if (unknown.size() > 1) {
    std::vector<std::string> others;
    for (size_t i = 1; i < unknown.size(); ++i) {
      others.push_back(unknown[i].context.empty() ? unknown[i].key
                                                  : unknown[i].context + "." + unknown[i].key);
    }
    message += "; also unknown: " + internal::JoinChoices(others);
  }
  throw Error(message);
}

void OptionsReader::FailType(const std::string& position, const std::string& qualified,
                             const YAML::Node& node, const char* expected) const {
  Fail(position, ": key '", qualified, "': expected ", expected, ", got ", Describe(node));
}

void OptionsReader::FailRange(const std::string& key, const std::string& value,
                              const std::string& min, const std::string& max) const {
  Fail(Where(key), ": value ", value, " is out of range [", min, ", ", max, "]");
}

namespace {

// What a value of type T must look like, for FailType.
template <typename T>
const char* Expected() {
  if constexpr (std::is_same_v<T, bool>) return "a boolean (true/false)";
  if constexpr (std::is_same_v<T, int>) return "an integer (32-bit)";
  if constexpr (std::is_same_v<T, int64_t>) return "an integer";
  if constexpr (std::is_same_v<T, uint64_t>) return "a non-negative integer";
  return "a number";
}

}  // namespace

template <typename T>
void OptionsReader::Convert(const std::string& qualified, const YAML::Node& node, const Pos& position,
                            T* value) const {
  static_assert(std::is_arithmetic_v<T>, "Convert: a number or a boolean");
  bool converted = node.IsScalar();
  if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
    converted = converted && ParseInteger(node.Scalar(), value);
  } else {
    converted = converted && YAML::convert<T>::decode(node, *value);
  }
  if (!converted) FailType(position, qualified, node, Expected<T>());
}

template void OptionsReader::Convert(const std::string&, const YAML::Node&, const Pos&, bool*) const;
template void OptionsReader::Convert(const std::string&, const YAML::Node&, const Pos&, int*) const;
template void OptionsReader::Convert(const std::string&, const YAML::Node&, const Pos&, int64_t*) const;
template void OptionsReader::Convert(const std::string&, const YAML::Node&, const Pos&, uint64_t*) const;
template void OptionsReader::Convert(const std::string&, const YAML::Node&, const Pos&, double*) const;
template void OptionsReader::Convert(const std::string&, const YAML::Node&, const Pos&, float*) const;

void OptionsReader::Convert(const std::string& qualified, const YAML::Node& node,
                            const Pos& position, std::string* value) const {
  if (!node.IsScalar()) FailType(position, qualified, node, "a string");
  *value = node.Scalar();
}

template <typename E>
void OptionsReader::Convert(const std::string& qualified, const YAML::Node& node,
                            const Pos& position, std::vector<E>* value) const {
  if (!node.IsSequence()) {
    const char* expected = std::is_same_v<E, std::string> ? "a list of strings"
                           : std::is_same_v<E, int>       ? "a list of integers"
                                                          : "a list of numbers";
    FailType(position, qualified, node, expected);
  }
  value->clear();
  for (size_t i = 0; i < node.size(); ++i) {
    const YAML::Node element = node[i];
    E converted{};
    Convert(qualified + "[" + std::to_string(i) + "]", element, Position(element), &converted);
    value->push_back(std::move(converted));
  }
}

template void OptionsReader::Convert(const std::string&, const YAML::Node&, const Pos&,
                                     std::vector<double>*) const;
template void OptionsReader::Convert(const std::string&, const YAML::Node&, const Pos&,
                                     std::vector<int>*) const;
template void OptionsReader::Convert(const std::string&, const YAML::Node&, const Pos&,
                                     std::vector<std::string>*) const;

namespace internal {

std::string JoinChoices(const std::vector<std::string>& choices) {
  std::string text;
  for (const std::string& choice : choices) text += (text.empty() ? "" : ", ") + choice;
  return text;
}

std::string ChoiceError(const std::string& value, const std::vector<std::string>& choices) {
  if (std::find(choices.begin(), choices.end(), value) != choices.end()) return "";
  std::string error = "'" + value + "' is not one of " + JoinChoices(choices);
  const std::string suggestion = Suggest(value, choices);
  if (!suggestion.empty()) error += " (did you mean '" + suggestion + "'?)";
  return error;
}

}  // namespace internal

}  // namespace relit
