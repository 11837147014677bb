#include "core/json_file.h"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/atomic_output.h"
#include "core/error.h"

namespace relit {

namespace {

using nlohmann::json;

// A short rendering of a JSON value for error messages.
std::string Preview(const json& j) {
  std::string text = j.dump();
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  return text;
}

// Removes nlohmann's "[json.exception.parse_error.101] " prefix; the rest
// already says "parse error at line L, column C: ...".
std::string StripExceptionId(const std::string& what) {
  if (!what.empty() && what[0] == '[') {
    const size_t end = what.find("] ");
    if (end != std::string::npos) return what.substr(end + 2);
  }
  return what;
}

// Splits "relit.<kind>/<version>"; false when `schema` has another shape.
bool ParseSchema(const std::string& schema, std::string* kind, int* version) {
  const std::string prefix = "relit.";
  const size_t slash = schema.rfind('/');
  if (schema.compare(0, prefix.size(), prefix) != 0 || slash == std::string::npos ||
      slash <= prefix.size() || slash + 1 >= schema.size()) {
    return false;
  }
  const std::string digits = schema.substr(slash + 1);
  if (digits.size() > 6 || digits.find_first_not_of("0123456789") != std::string::npos) {
    return false;
  }
  *kind = schema.substr(prefix.size(), slash - prefix.size());
  *version = std::stoi(digits);
  return true;
}

const char* TypeName(const json& j) {
  if (j.is_null()) return "null";
  if (j.is_boolean()) return "a boolean";
  if (j.is_number()) return "a number";
  if (j.is_string()) return "a string";
  if (j.is_array()) return "an array";
  return "an object";
}

}  // namespace

std::string SchemaString(const std::string& kind, int version) {
  return "relit." + kind + "/" + std::to_string(version);
}

nlohmann::json ReadJsonFile(const std::string& path, const std::string& kind, int version) {
  const std::string expected = SchemaString(kind, version);
  std::error_code ec;
  RELIT_REQUIRE(std::filesystem::exists(path, ec), "cannot read ", path,
                ": file does not exist (expected a ", expected,
                " file; run the stage that writes it)");
  RELIT_REQUIRE(!std::filesystem::is_directory(path, ec), "cannot read ", path,
                ": it is a directory, expected a ", expected, " file");
  std::ifstream stream(path, std::ios::binary);
  RELIT_REQUIRE(stream.good(), "cannot open ", path, ": ", std::strerror(errno));
  std::ostringstream content;
  content << stream.rdbuf();
  RELIT_REQUIRE(!stream.bad(), "cannot read ", path, ": ", std::strerror(errno));

  json document;
  try {
    document = json::parse(content.str());
  } catch (const json::parse_error& e) {
    Fail(path, ": invalid JSON: ", StripExceptionId(e.what()), " (expected a ", expected,
         " file)");
  } catch (const json::exception& e) {
    // e.g. a number too large for a double (1e400): out_of_range, not parse_error.
    Fail(path, ": invalid JSON: ", StripExceptionId(e.what()), " (expected a ", expected,
         " file; numbers must fit a double)");
  }

  RELIT_REQUIRE(document.is_object(), path, ": expected a JSON object with \"schema\": \"",
                expected, "\", found ", TypeName(document));
  const auto schema_it = document.find("schema");
  RELIT_REQUIRE(schema_it != document.end(), path, " has no \"schema\" field, expected \"",
                expected, "\"; it was not written by relit or by a very old version, "
                "rerun the stage that writes it");
  RELIT_REQUIRE(schema_it->is_string(), path, ": \"schema\" must be a string like \"",
                expected, "\", found ", Preview(*schema_it));
  const std::string schema = schema_it->get<std::string>();
  std::string found_kind;
  int found_version = 0;
  RELIT_REQUIRE(ParseSchema(schema, &found_kind, &found_version), path, " has schema \"",
                schema, "\", expected \"", expected, "\"; this is not a relit file");
  RELIT_REQUIRE(found_kind == kind, path, " is a ", schema, " file, expected ", expected,
                "; check which file was passed");
  RELIT_REQUIRE(found_version <= version, path, " was written by a newer relit (", schema,
                "), this build reads ", expected, "; rerun the stage that writes it");
  RELIT_REQUIRE(found_version >= version, path, " was written by an older relit (", schema,
                "), this build reads ", expected, "; rerun the stage that writes it");
  return document;
}

void WriteJsonFile(const std::string& path, const std::string& kind, int version,
                   nlohmann::json body) {
  RELIT_CHECK(body.is_object() || body.is_null());
  // nlohmann::json keeps keys sorted; ordered_json keeps insertion order, so
  // "schema" can come first and tell a reader at a glance what the file is.
  nlohmann::ordered_json document;
  document["schema"] = SchemaString(kind, version);
  if (body.is_object()) {
    for (auto& [key, value] : body.items()) {
      if (key != "schema") document[key] = nlohmann::ordered_json(std::move(value));
    }
  }
  std::string text;
  try {
    text = document.dump(2) + "\n";
  } catch (const nlohmann::json::exception& e) {
    Fail("cannot write ", path, ": ", StripExceptionId(e.what()));
  }
  AtomicWriteFile(path, text);
}

const nlohmann::json& JsonField(const nlohmann::json& object, const std::string& key,
                                const std::string& where) {
  RELIT_REQUIRE(object.is_object(), where, ": expected an object with field '", key,
                "', got ", Preview(object));
  const auto it = object.find(key);
  RELIT_REQUIRE(it != object.end(), where, ": missing field '", key, "'");
  return *it;
}

double JsonNumber(const nlohmann::json& object, const std::string& key, const std::string& where) {
  const json& value = JsonField(object, key, where);
  RELIT_REQUIRE(value.is_number(), where, ": field '", key, "': expected a number, got ",
                Preview(value));
  return value.get<double>();
}

int JsonInt(const nlohmann::json& object, const std::string& key, const std::string& where) {
  const json& value = JsonField(object, key, where);
  RELIT_REQUIRE(value.is_number_integer() &&
                    value.get<int64_t>() >= std::numeric_limits<int>::min() &&
                    value.get<int64_t>() <= std::numeric_limits<int>::max(),
                where, ": field '", key, "': expected an integer, got ", Preview(value));
  return value.get<int>();
}

std::string JsonString(const nlohmann::json& object, const std::string& key,
                       const std::string& where) {
  const json& value = JsonField(object, key, where);
  RELIT_REQUIRE(value.is_string(), where, ": field '", key, "': expected a string, got ",
                Preview(value));
  return value.get<std::string>();
}

void JsonListError(const std::string& where, const std::string& key) {
  Fail(where, ": '", key, "' must be a list");
}

namespace {

// Reads an array of exactly n numbers.
template <int n>
Eigen::Matrix<double, n, 1> FixedVectorFromJson(const json& j, const std::string& where) {
  RELIT_REQUIRE(j.is_array() && j.size() == static_cast<size_t>(n), where, ": expected an array of ",
                n, " numbers, got ", Preview(j));
  Eigen::Matrix<double, n, 1> v;
  for (int i = 0; i < n; ++i) {
    RELIT_REQUIRE(j[i].is_number(), where, ": expected an array of ", n, " numbers, got ",
                  Preview(j));
    v[i] = j[i].get<double>();
  }
  return v;
}

}  // namespace

nlohmann::json ToJson(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

Eigen::Vector3d Vector3FromJson(const nlohmann::json& j, const std::string& where) {
  return FixedVectorFromJson<3>(j, where);
}

nlohmann::json ToJson(const Rigid3& transform) {
  const Eigen::Quaterniond& q = transform.rotation;
  return json{{"rotation_wxyz", json::array({q.w(), q.x(), q.y(), q.z()})},
              {"translation_m", ToJson(transform.translation)}};
}

Rigid3 Rigid3FromJson(const nlohmann::json& j, const std::string& where) {
  const Eigen::Vector4d wxyz =
      FixedVectorFromJson<4>(JsonField(j, "rotation_wxyz", where), where + ".rotation_wxyz");
  RELIT_REQUIRE(std::abs(wxyz.norm() - 1.0) < 1e-3, where,
                ".rotation_wxyz: expected a unit quaternion, got norm ", wxyz.norm());
  const Eigen::Vector3d t =
      Vector3FromJson(JsonField(j, "translation_m", where), where + ".translation_m");
  return Rigid3(Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]), t);
}

nlohmann::json ToJson(const Intrinsics& k) {
  const Distortion& d = k.distortion;
  return json{{"width", k.width},
              {"height", k.height},
              {"fx", k.fx},
              {"fy", k.fy},
              {"cx", k.cx},
              {"cy", k.cy},
              {"distortion", {{"k1", d.k1}, {"k2", d.k2}, {"p1", d.p1}, {"p2", d.p2}, {"k3", d.k3}}}};
}

Intrinsics IntrinsicsFromJson(const nlohmann::json& j, const std::string& where) {
  Intrinsics k;
  k.width = JsonInt(j, "width", where);
  k.height = JsonInt(j, "height", where);
  k.fx = JsonNumber(j, "fx", where);
  k.fy = JsonNumber(j, "fy", where);
  k.cx = JsonNumber(j, "cx", where);
  k.cy = JsonNumber(j, "cy", where);
  const json& d = JsonField(j, "distortion", where);
  const std::string d_where = where + ".distortion";
  k.distortion.k1 = JsonNumber(d, "k1", d_where);
  k.distortion.k2 = JsonNumber(d, "k2", d_where);
  k.distortion.p1 = JsonNumber(d, "p1", d_where);
  k.distortion.p2 = JsonNumber(d, "p2", d_where);
  k.distortion.k3 = JsonNumber(d, "k3", d_where);
  try {
    k.Check();
  } catch (const Error& e) {
    Fail(where, ": ", e.what());
  }
  return k;
}

}  // namespace relit
