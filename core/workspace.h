// Files that stages exchange in a workspace, as C++ structs with one reader
// and one writer each. Stages never link each other: they share these
// formats through core. Paths inside the files are relative to the workspace
// root so a workspace can be moved. docs/formats.md describes every field.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include <nlohmann/json.hpp>

#include "core/board.h"
#include "core/camera.h"

namespace relit {

// --- calib/cameras.json (relit.cameras/1) ----------------------------------
struct CalibratedFrame {
  std::string name;         // e.g. "view/000012"; lexical order = time per device
  std::string device;       // "view" or "light"
  double time_s = 0;        // presentation time on the common clock (phone V's)
  Rigid3 cam_from_world;    // world = board frame, +Z up, metres
  // Undistorted pinhole images (phone V only; empty for light frames):
  std::string image_linear;  // half EXR, linear RGB
  std::string image_8bit;    // sRGB PNG for geometry
};

struct CamerasFile {
  static constexpr const char* kKind = "cameras";
  static constexpr int kVersion = 1;
  BoardSpec board;
  // Calibrated lens of each device as recorded (with distortion).
  std::map<std::string, Intrinsics> devices;
  // Pinhole camera of the undistorted phone V images.
  Intrinsics undistorted_view;
  std::vector<CalibratedFrame> frames;

  std::vector<const CalibratedFrame*> FramesOf(const std::string& device) const;
  const CalibratedFrame* Find(const std::string& name) const;
  // The undistorted pinhole camera of a view frame.
  Camera ViewCamera(const CalibratedFrame& frame) const;
};
CamerasFile ReadCamerasFile(const std::string& path);
void WriteCamerasFile(const std::string& path, const CamerasFile& file);

// --- calib/lights.json (relit.lights/1) ------------------------------------
struct FrameLight {
  std::string view_frame;        // name of the phone V frame it lights
  double time_s = 0;             // common clock
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // flash position, world
  double nearest_light_gap_s = 0;  // time to the nearest registered L frame
  bool reliable = true;          // false when the L poses around it are too far in time
};

struct LightsFile {
  static constexpr const char* kKind = "lights";
  static constexpr int kVersion = 1;
  Eigen::Vector3d flash_offset_m = Eigen::Vector3d::Zero();  // in phone L's camera frame
  std::vector<FrameLight> frames;

  const FrameLight* Find(const std::string& view_frame) const;
};
LightsFile ReadLightsFile(const std::string& path);
void WriteLightsFile(const std::string& path, const LightsFile& file);

// --- reconstruct/proxy.json (relit.proxy/1) ---------------------------------
struct ViewMatte {
  std::string view_frame;
  std::string matte;    // 16-bit PNG, alpha in [0, 1]
  std::string trimap;   // 8-bit PNG, 0 / 128 / 255
};

struct ProxyFile {
  static constexpr const char* kKind = "proxy";
  static constexpr int kVersion = 1;
  std::string mesh;                 // OBJ with per-corner UVs, world frame, metres
  int atlas_resolution_px = 512;    // texture size the UV atlas was packed for
  Eigen::Vector3d object_centre_m = Eigen::Vector3d::Zero();  // partitions are centred here
  double object_radius_m = 0;       // bounding sphere radius
  // Object-space normal map of the mesh (float RGB EXR read at the UVs; zero
  // texels keep the mesh normal), "" = none. Optional key: older files have none.
  std::string normal_map;
  std::vector<ViewMatte> mattes;

  const ViewMatte* Find(const std::string& view_frame) const;
};
ProxyFile ReadProxyFile(const std::string& path);
void WriteProxyFile(const std::string& path, const ProxyFile& file);

nlohmann::json ToJson(const BoardSpec& board);
BoardSpec BoardSpecFromJson(const nlohmann::json& j, const std::string& where);

}  // namespace relit
