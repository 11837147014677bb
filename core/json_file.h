// Versioned JSON files and JSON conversions for the core types.
//
// Every JSON file relit writes carries a top-level "schema" field
// "relit.<kind>/<version>", e.g. "relit.cameras/2". Readers state the kind
// and the one version they understand; anything else is refused with a
// message that says which stage to rerun, instead of failing later on a
// missing field. Bump the version whenever a field changes meaning or is
// removed (adding an optional field does not need a bump).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/camera.h"

namespace relit {

// "relit.<kind>/<version>".
std::string SchemaString(const std::string& kind, int version);

// Reads and parses `path` and checks its schema. Returns the whole document
// (including "schema"). Throws relit::Error naming the file for a missing
// file, invalid JSON (with line and column), a missing schema, another kind
// or another version.
nlohmann::json ReadJsonFile(const std::string& path, const std::string& kind, int version);

// Writes `body` (an object or null) with "schema" set to
// SchemaString(kind, version) as the first field, pretty-printed with
// 2-space indent. Any "schema" already in `body` is replaced. Parent
// directories are created; the file is replaced atomically.
void WriteJsonFile(const std::string& path, const std::string& kind, int version,
                   nlohmann::json body);

// Conversions. The FromJson functions throw relit::Error for missing or
// mistyped fields; `where` (e.g. "cameras.json: frames[3]") prefixes their
// messages. Note that JSON has no NaN/Inf: they are written as null and
// rejected when read back.

// [x, y, z]
nlohmann::json ToJson(const Eigen::Vector3d& v);
Eigen::Vector3d Vector3FromJson(const nlohmann::json& j, const std::string& where = "vector");

// {"rotation_wxyz": [w, x, y, z], "translation_m": [x, y, z]}
nlohmann::json ToJson(const Rigid3& transform);
Rigid3 Rigid3FromJson(const nlohmann::json& j, const std::string& where = "transform");

// {"width", "height", "fx", "fy", "cx", "cy",
//  "distortion": {"k1", "k2", "p1", "p2", "k3"}}
// Intrinsics::Check() is applied when reading.
nlohmann::json ToJson(const Intrinsics& intrinsics);
Intrinsics IntrinsicsFromJson(const nlohmann::json& j, const std::string& where = "intrinsics");

// Field access with relit::Error on absence or wrong type, for writing
// further FromJson functions in the same style.
const nlohmann::json& JsonField(const nlohmann::json& object, const std::string& key,
                                const std::string& where);
double JsonNumber(const nlohmann::json& object, const std::string& key, const std::string& where);
int JsonInt(const nlohmann::json& object, const std::string& key, const std::string& where);
std::string JsonString(const nlohmann::json& object, const std::string& key,
                       const std::string& where);

// Throws "<where>: '<key>' must be a list".
[[noreturn]] void JsonListError(const std::string& where, const std::string& key);

// The list `key` of `object`, read one item at a time: `read_item(item,
// where)`, where = "<where>: key[i]" names the item in its messages. A key
// that is not a list is refused.
template <typename Item, typename ReadItem>
std::vector<Item> ReadJsonList(const nlohmann::json& object, const std::string& key, const std::string& where,
                               ReadItem read_item) {
  const nlohmann::json& list = JsonField(object, key, where);
  if (!list.is_array()) JsonListError(where, key);
  std::vector<Item> items;
  for (size_t i = 0; i < list.size(); ++i) {
    items.push_back(read_item(list[i], where + ": " + key + "[" + std::to_string(i) + "]"));
  }
  return items;
}
// The JSON list of `items`, one `to_json(item)` each.
template <typename Item, typename ToJsonFn>
nlohmann::json JsonList(const std::vector<Item>& items, ToJsonFn to_json) {
  nlohmann::json list = nlohmann::json::array();
  for (const Item& item : items) list.push_back(to_json(item));
  return list;
}

}  // namespace relit
