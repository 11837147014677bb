#include "core/workspace.h"

#include "core/error.h"
#include "core/json_file.h"

namespace relit {

namespace {
using nlohmann::json;

template <typename T>
const T* FindByName(const std::vector<T>& items, const std::string& name, std::string T::*field) {
  for (const T& item : items) {
    if (item.*field == name) return &item;
  }
  return nullptr;
}

bool JsonBool(const json& object, const std::string& key, const std::string& where) {
  const json& value = JsonField(object, key, where);
  RELIT_REQUIRE(value.is_boolean(), where, ": field '", key, "' must be true or false");
  return value.get<bool>();
}
}  // namespace

json ToJson(const BoardSpec& board) { return OptionsToJson(board); }

BoardSpec BoardSpecFromJson(const json& j, const std::string& where) {
  BoardSpec board;
  board.squares_x = JsonInt(j, "squares_x", where);
  board.squares_y = JsonInt(j, "squares_y", where);
  board.square_length_m = JsonNumber(j, "square_length_m", where);
  board.marker_length_m = JsonNumber(j, "marker_length_m", where);
  board.dictionary = JsonString(j, "dictionary", where);
  CheckOptions(board);
  return board;
}

std::vector<const CalibratedFrame*> CamerasFile::FramesOf(const std::string& device) const {
  std::vector<const CalibratedFrame*> result;
  for (const CalibratedFrame& frame : frames) {
    if (frame.device == device) result.push_back(&frame);
  }
  return result;
}

const CalibratedFrame* CamerasFile::Find(const std::string& name) const {
  return FindByName(frames, name, &CalibratedFrame::name);
}

Camera CamerasFile::ViewCamera(const CalibratedFrame& frame) const {
  return Camera(undistorted_view, frame.cam_from_world);
}

CamerasFile ReadCamerasFile(const std::string& path) {
  const json j = ReadJsonFile(path, CamerasFile::kKind, CamerasFile::kVersion);
  CamerasFile file;
  file.board = BoardSpecFromJson(JsonField(j, "board", path), path + ": board");
  for (const auto& [name, value] : JsonField(j, "devices", path).items()) {
    file.devices[name] = IntrinsicsFromJson(value, path + ": devices." + name);
  }
  file.undistorted_view = IntrinsicsFromJson(JsonField(j, "undistorted_view", path), path + ": undistorted_view");
  file.frames = ReadJsonList<CalibratedFrame>(j, "frames", path, [&](const json& item, const std::string& where) {
    CalibratedFrame frame;
    frame.name = JsonString(item, "name", where);
    frame.device = JsonString(item, "device", where);
    RELIT_REQUIRE(file.devices.count(frame.device), where, ": unknown device '", frame.device, "'");
    frame.time_s = JsonNumber(item, "time_s", where);
    frame.cam_from_world = Rigid3FromJson(JsonField(item, "cam_from_world", where), where);
    frame.image_linear = JsonString(item, "image_linear", where);
    frame.image_8bit = JsonString(item, "image_8bit", where);
    return frame;
  });
  return file;
}

void WriteCamerasFile(const std::string& path, const CamerasFile& file) {
  json devices = json::object();
  for (const auto& [name, intrinsics] : file.devices) devices[name] = ToJson(intrinsics);
  const json frames = JsonList(file.frames, [](const CalibratedFrame& frame) {
    return json{{"name", frame.name},
                {"device", frame.device},
                {"time_s", frame.time_s},
                {"cam_from_world", ToJson(frame.cam_from_world)},
                {"image_linear", frame.image_linear},
                {"image_8bit", frame.image_8bit}};
  });
  WriteJsonFile(path, CamerasFile::kKind, CamerasFile::kVersion,
                {{"units", "metres; world = board frame, +Z up"},
                 {"board", ToJson(file.board)},
                 {"devices", devices},
                 {"undistorted_view", ToJson(file.undistorted_view)},
                 {"frames", frames}});
}

const FrameLight* LightsFile::Find(const std::string& view_frame) const {
  return FindByName(frames, view_frame, &FrameLight::view_frame);
}

LightsFile ReadLightsFile(const std::string& path) {
  const json j = ReadJsonFile(path, LightsFile::kKind, LightsFile::kVersion);
  LightsFile file;
  file.flash_offset_m = Vector3FromJson(JsonField(j, "flash_offset_m", path), path + ": flash_offset_m");
  file.frames = ReadJsonList<FrameLight>(j, "frames", path, [](const json& item, const std::string& where) {
    FrameLight light;
    light.view_frame = JsonString(item, "view_frame", where);
    light.time_s = JsonNumber(item, "time_s", where);
    light.position_m = Vector3FromJson(JsonField(item, "position_m", where), where);
    light.nearest_light_gap_s = JsonNumber(item, "nearest_light_gap_s", where);
    light.reliable = JsonBool(item, "reliable", where);
    return light;
  });
  return file;
}

void WriteLightsFile(const std::string& path, const LightsFile& file) {
  const json frames = JsonList(file.frames, [](const FrameLight& light) {
    return json{{"view_frame", light.view_frame},
                {"time_s", light.time_s},
                {"position_m", ToJson(light.position_m)},
                {"nearest_light_gap_s", light.nearest_light_gap_s},
                {"reliable", light.reliable}};
  });
  WriteJsonFile(path, LightsFile::kKind, LightsFile::kVersion,
                {{"units", "metres; world = board frame, +Z up"},
                 {"flash_offset_m", ToJson(file.flash_offset_m)},
                 {"frames", frames}});
}

const ViewMatte* ProxyFile::Find(const std::string& view_frame) const {
  return FindByName(mattes, view_frame, &ViewMatte::view_frame);
}

ProxyFile ReadProxyFile(const std::string& path) {
  const json j = ReadJsonFile(path, ProxyFile::kKind, ProxyFile::kVersion);
  ProxyFile file;
  file.mesh = JsonString(j, "mesh", path);
  file.atlas_resolution_px = JsonInt(j, "atlas_resolution_px", path);
  file.object_centre_m = Vector3FromJson(JsonField(j, "object_centre_m", path), path + ": object_centre_m");
  file.object_radius_m = JsonNumber(j, "object_radius_m", path);
  if (j.contains("normal_map")) file.normal_map = JsonString(j, "normal_map", path);
  file.mattes = ReadJsonList<ViewMatte>(j, "mattes", path, [](const json& item, const std::string& where) {
    return ViewMatte{JsonString(item, "view_frame", where), JsonString(item, "matte", where),
                     JsonString(item, "trimap", where)};
  });
  return file;
}

void WriteProxyFile(const std::string& path, const ProxyFile& file) {
  const json mattes = JsonList(file.mattes, [](const ViewMatte& m) {
    return json{{"view_frame", m.view_frame}, {"matte", m.matte}, {"trimap", m.trimap}};
  });
  json j = {{"mesh", file.mesh},
            {"atlas_resolution_px", file.atlas_resolution_px},
            {"object_centre_m", ToJson(file.object_centre_m)},
            {"object_radius_m", file.object_radius_m},
            {"mattes", mattes}};
  if (!file.normal_map.empty()) j["normal_map"] = file.normal_map;
  WriteJsonFile(path, ProxyFile::kKind, ProxyFile::kVersion, j);
}

}  // namespace relit
