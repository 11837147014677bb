#include "core/capture_file.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/error.h"
#include "core/json_file.h"

namespace relit {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// An optional field: `fallback` when absent or null, an error when it has
// another type (a hand-edited or damaged file must not throw a raw JSON
// exception).
double OptionalNumber(const json& object, const char* key, const std::string& where, double fallback) {
  if (!object.contains(key) || object[key].is_null()) return fallback;
  return JsonNumber(object, key, where);
}

int OptionalInt(const json& object, const char* key, const std::string& where, int fallback) {
  if (!object.contains(key) || object[key].is_null()) return fallback;
  return JsonInt(object, key, where);
}

const json& OptionalList(const json& object, const char* key, const std::string& path) {
  static const json kEmpty = json::array();
  if (!object.contains(key) || object[key].is_null()) return kEmpty;
  RELIT_REQUIRE(object[key].is_array(), path, ": '", key, "' must be a list");
  return object[key];
}

// The frame's own size (geometry-pass photos record one per photo).
void ReadOwnSize(const json& frame, const std::string& where, int* width, int* height) {
  const bool output = frame.contains("output_width_px");
  *width = OptionalInt(frame, output ? "output_width_px" : "width_px", where, 0);
  *height = OptionalInt(frame, output ? "output_height_px" : "height_px", where, 0);
}

std::vector<CaptureFrame> ReadFrames(const json& capture, const std::string& key, const std::string& device,
                                     const std::string& path) {
  // Geometry-pass photos carry no time: their file order is their order.
  const bool untimed = device == "geometry";
  const json& frames = JsonField(capture, key, path);
  RELIT_REQUIRE(frames.is_array(), path, ": '", key, "' must be a list");
  std::vector<CaptureFrame> result;
  for (size_t i = 0; i < frames.size(); ++i) {
    const std::string where = path + ": " + key + "[" + std::to_string(i) + "]";
    RELIT_REQUIRE(frames[i].is_object(), where, " must be an object");
    CaptureFrame frame;
    frame.device = device;
    frame.index = JsonInt(frames[i], "index", where);
    char name[64];
    std::snprintf(name, sizeof(name), "%s/%06d", device.c_str(), frame.index);
    frame.name = name;
    frame.time_s = untimed && !frames[i].contains("time_s") ? frame.index : JsonNumber(frames[i], "time_s", where);
    frame.source_frame = OptionalInt(frames[i], "source_frame", where, -1);
    frame.image = "capture/" + JsonString(frames[i], "image", where);
    if (frames[i].contains("linear")) frame.linear = "capture/" + JsonString(frames[i], "linear", where);
    frame.sharpness = OptionalNumber(frames[i], "sharpness", where, NAN);
    ReadOwnSize(frames[i], where, &frame.width_px, &frame.height_px);
    result.push_back(frame);
  }
  std::sort(result.begin(), result.end(),
            [](const CaptureFrame& a, const CaptureFrame& b) { return a.index < b.index; });
  for (size_t i = 1; i < result.size(); ++i) {
    RELIT_REQUIRE(result[i].time_s > result[i - 1].time_s, path, ": ", key, " are not in time order (",
                  result[i - 1].name, " at ", result[i - 1].time_s, " s, ", result[i].name, " at ",
                  result[i].time_s, " s): rerun relit-capture");
  }
  return result;
}

std::vector<RejectedFrame> ReadRejected(const json& capture, const std::string& path) {
  const json& frames = OptionalList(capture, "rejected_view_frames", path);
  std::vector<RejectedFrame> result;
  for (size_t i = 0; i < frames.size(); ++i) {
    const std::string where = path + ": rejected_view_frames[" + std::to_string(i) + "]";
    RELIT_REQUIRE(frames[i].is_object(), where, " must be an object");
    RejectedFrame frame;
    frame.time_s = OptionalNumber(frames[i], "time_s", where, NAN);
    frame.sharpness = OptionalNumber(frames[i], "sharpness", where, NAN);
    frame.reason = frames[i].contains("reason") ? JsonString(frames[i], "reason", where) : "?";
    result.push_back(frame);
  }
  return result;
}

// A video's display rotation (0 when not recorded).
int ReadRotation(const json& input, const std::string& where) {
  const int rotation = OptionalInt(input, "rotation_deg", where, 0);
  RELIT_REQUIRE(rotation == 0 || rotation == 90 || rotation == 180 || rotation == 270, where,
                ".rotation_deg must be 0, 90, 180 or 270, got ", rotation);
  return rotation;
}

// A phone's entry of `inputs`: its output size is required.
CaptureSource ReadPhone(const json& inputs, const std::string& device, const std::string& path) {
  const std::string where = path + ": inputs." + device;
  const json& input = JsonField(inputs, device, path + ": inputs");
  RELIT_REQUIRE(input.is_object(), where, " must be an object");
  CaptureSource source;
  source.output_width_px = JsonInt(input, "output_width_px", where);
  source.output_height_px = JsonInt(input, "output_height_px", where);
  RELIT_REQUIRE(source.output_width_px > 0 && source.output_height_px > 0, where, ": image size must be positive");
  if (input.contains("transfer_used") && !input["transfer_used"].is_null()) {
    source.transfer_used = JsonString(input, "transfer_used", where);
  }
  source.rotation_deg = ReadRotation(input, where);
  return source;
}

// The geometry pass's entry: a video (one size) or a photo folder (a size per photo).
CaptureSource ReadGeometrySource(const json& inputs, const std::string& path) {
  const std::string where = path + ": inputs.geometry";
  const json& input = JsonField(inputs, "geometry", path + ": inputs");
  RELIT_REQUIRE(input.is_object(), where, " must be an object");
  CaptureSource source;
  source.type = input.contains("type") ? JsonString(input, "type", where) : "";
  ReadOwnSize(input, where, &source.output_width_px, &source.output_height_px);
  source.rotation_deg = ReadRotation(input, where);
  return source;
}

void ReadCounts(const json& capture, const std::string& path, CaptureFile* file) {
  if (!capture.contains("counts") || capture["counts"].is_null()) return;
  const std::string where = path + ": counts";
  const json& counts = capture["counts"];
  RELIT_REQUIRE(counts.is_object(), where, " must be an object");
  if (counts.contains("view") && counts["view"].is_object()) {
    for (auto it = counts["view"].begin(); it != counts["view"].end(); ++it) {
      file->view_counts[it.key()] = JsonInt(counts["view"], it.key(), where + ".view");
    }
  }
  if (counts.contains("light_usable") && !counts["light_usable"].is_null()) {
    file->light_usable = JsonInt(counts, "light_usable", where);
  }
  if (counts.contains("light_kept") && !counts["light_kept"].is_null()) {
    file->light_kept = JsonInt(counts, "light_kept", where);
  }
}

}  // namespace

const CaptureFrame* CaptureFile::Find(const std::string& name) const {
  for (const std::vector<CaptureFrame>* frames : {&view, &light, &geometry}) {
    for (const CaptureFrame& frame : *frames) {
      if (frame.name == name) return &frame;
    }
  }
  return nullptr;
}

std::string CaptureFilePath(const std::string& workspace) {
  return (fs::path(workspace) / "capture" / "capture.json").string();
}

CaptureFile ReadCaptureFile(const std::string& path) {
  const json capture = ReadJsonFile(path, CaptureFile::kKind, CaptureFile::kVersion);
  RELIT_REQUIRE(capture.is_object(), path, " must hold a JSON object");
  CaptureFile file;
  file.view = ReadFrames(capture, "view_frames", "view", path);
  file.light = ReadFrames(capture, "light_frames", "light", path);
  const json& inputs = JsonField(capture, "inputs", path);
  RELIT_REQUIRE(inputs.is_object(), path, ": 'inputs' must be an object");
  file.inputs["view"] = ReadPhone(inputs, "view", path);
  file.inputs["light"] = ReadPhone(inputs, "light", path);
  if (capture.contains("sync") && !capture["sync"].is_null()) {
    file.sync = capture["sync"];
    RELIT_REQUIRE(file.sync.is_object(), path, ": 'sync' must be an object");
    file.sync_offset_s = OptionalNumber(file.sync, "offset_s", path + ": sync", 0.0);
  }
  if (!OptionalList(capture, "geometry_frames", path).empty()) {
    file.geometry = ReadFrames(capture, "geometry_frames", "geometry", path);
    file.inputs["geometry"] = ReadGeometrySource(inputs, path);
  }
  file.rejected_view = ReadRejected(capture, path);
  ReadCounts(capture, path, &file);
  return file;
}

}  // namespace relit
