// Interop exports: options, shared helpers and the export of all three
// (interop.h).
#include "relight/interop.h"

#include <filesystem>
#include <system_error>

#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/options.h"
#include "core/run_record.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;




CamerasFile ReadCalibCameras(const std::string& workspace) {
  const fs::path path = fs::absolute(workspace) / "calib" / "cameras.json";
  RELIT_REQUIRE(fs::exists(path), path.string(), " is missing: run relit-calib first");
  return ReadCamerasFile(path.string());
}

int LinkOrCopyFile(const std::string& from, const std::string& to, bool link) {
  fs::create_directories(fs::path(to).parent_path());
  if (link) {
    std::error_code error;
    fs::create_hard_link(from, to, error);
    if (!error) return 1;  // e.g. another file system: copy instead
  }
  std::error_code error;
  fs::copy_file(from, to, fs::copy_options::overwrite_existing, error);
  RELIT_REQUIRE(!error, "cannot copy ", from, " to ", to, ": ", error.message());
  return 0;
}

namespace {

const char* kReadme =
    "# relit interop exports\n\n"
    "Written by `relit-relight export` (docs/formats.md, \"Interop exports\"). World frame: the ChArUco\n"
    "board frame, metres, +Z up. The cameras are the undistorted phone V frames (pinhole, no distortion).\n\n"
    "- `colmap/`: COLMAP text model `sparse/0/{cameras,images,points3D}.txt` (one PINHOLE camera,\n"
    "  cam_from_world poses, the proxy's vertices as points without tracks) and `images/` (the\n"
    "  undistorted 8-bit sRGB frames it names). `colmap model_converter` turns it into .bin; the\n"
    "  layout is what COLMAP's dense tools, nerfstudio and Gaussian-splatting trainers read.\n"
    "- `nerf/`: `transforms.json` (NeRF/nerfstudio style: fl_x, fl_y, cx, cy, w, h per frame,\n"
    "  `transform_matrix` camera-to-world with OpenGL camera axes x right, y up, z backwards, and\n"
    "  `pl_pos`, the flash position in world metres as in NRHints), `transforms_{train,val,test}.json`\n"
    "  (the relight plan's split), `images/` (undistorted linear EXR) and `masks/` (8-bit mattes).\n"
    "- `gltf/`: `preview.glb`, the proxy mesh with UVs and a preview texture baked from the trained\n"
    "  model under uniform white light (KHR_materials_unlit), plus the texture as PNG (sRGB) and EXR\n"
    "  (linear), and `bake.json` (views, coverage, timings).\n";

}  // namespace

void ExportInterop(const std::string& workspace, const std::string& out_dir, const InteropOptions& options,
                   RunRecord& record, ModelSet models) {
  CheckOptions(options, "export");
  fs::create_directories(out_dir);
  json summary = {{"folder", out_dir}, {"options", OptionsToJson(options)}};
  BakedTexture bake;
  {
    auto timer = record.Time("interop_gltf");
    summary["gltf"] = ExportGltf(workspace, (fs::path(out_dir) / "gltf").string(), options, &bake, models);
  }
  {
    auto timer = record.Time("interop_colmap");
    summary["colmap"] = ExportColmap(workspace, (fs::path(out_dir) / "colmap").string(), options, &bake);
  }
  {
    auto timer = record.Time("interop_nerf");
    summary["nerf"] = ExportNerf(workspace, (fs::path(out_dir) / "nerf").string(), options);
  }
  AtomicWriteFile(fs::path(out_dir) / "README.md", kReadme);
  record.Set("interop", summary);
  spdlog::info("interop: COLMAP, NeRF and glTF exports in {}", out_dir);
}

}  // namespace relit::relight
