// Interop exports written by `relit-relight export` next to the asset, in
// <asset>/interop/ (docs/formats.md, "Interop exports"):
//   colmap/   COLMAP text model (sparse/0/{cameras,images,points3D}.txt) of the
//             calibrated phone V cameras (one PINHOLE camera, the undistorted
//             frames) + images/ (the undistorted 8-bit frames it names);
//             points3D = the proxy's vertices (no tracks), coloured by the bake
//   nerf/     transforms.json (+ _train/_val/_test splits): per frame the
//             intrinsics, camera-to-world in the NeRF/OpenGL camera convention
//             and pl_pos (flash position, world metres, as NRHints), plus
//             images/ (undistorted linear EXR) and masks/ (8-bit PNG mattes)
//   gltf/     preview.glb: the proxy mesh with UVs, normals and a preview
//             texture baked from the trained model under uniform white light,
//             and the texture itself (preview_texture.png / .exr)
// Each folder is written atomically (AtomicDir), so a rerun replaces it whole.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/camera.h"
#include "core/image.h"
#include "core/render/mesh.h"
#include "core/workspace.h"
#include "relight/asset.h"
#include "relight/cue_frames.h"

namespace relit {
class RunRecord;
}  // namespace relit

namespace relit::relight {

class RelitRenderer;

struct InteropOptions {
  bool enabled = true;              // write <asset>/interop at all
  bool link_images = true;          // hard-link frames where possible (copy otherwise)
  // Preview bake (gltf/):
  int bake_views = 12;              // renders on the upper hemisphere around the object
  int bake_texture_px = 1024;       // square texture, power of two
  int bake_width_px = 0;            // render width; 0 = the training images' (multiple of 4)
  // Cue paths per pixel of each bake render; 0 = as the training cues (the
  // networks' output shifts with the cues' noise level).
  int bake_samples_per_pixel = 0;
  // Radiance of the uniform white environment, in the cues' unit (x
  // cues.flash_intensity): 1 makes a white Lambertian surface read ~1.
  double bake_environment_radiance = 1.0;
  double bake_exposure = 1.0;       // linear scale before the sRGB encoding of the texture

  static const OptionFields<InteropOptions>& Fields();
  void Check() const;  // across fields; ranges: CheckOptions
};

// --- COLMAP ------------------------------------------------------------------

// One image of a COLMAP model.
struct ColmapImage {
  std::string name;        // file name relative to the model's image folder
  Rigid3 cam_from_world;
};

// Writes cameras.txt (one PINHOLE camera, COLMAP's pixel convention: the
// top-left pixel's centre is (0.5, 0.5)), images.txt (empty 2D point lists)
// and points3D.txt (no tracks) into `dir`. `colors` is empty or one 8-bit RGB
// per point.
void WriteColmapPinholeModel(const std::string& dir, const Intrinsics& pinhole, const std::vector<ColmapImage>& images,
                             const std::vector<Eigen::Vector3d>& points,
                             const std::vector<Eigen::Vector3i>& colors);

// --- NeRF transforms.json ------------------------------------------------------

// Camera-to-world 4x4 in the NeRF/OpenGL camera convention (x right, y up,
// z backwards) from relit's OpenCV cam_from_world (x right, y down, z
// forward): world_from_cam * diag(1, -1, -1, 1).
Eigen::Matrix4d NerfTransformMatrix(const Rigid3& cam_from_world);
// Pixel (OpenCV convention, top-left pixel centre (0, 0)) of a world point
// under a transforms.json camera (corner convention: cx = relit cx + 0.5).
// False when the point is behind the camera.
bool ProjectWithNerfCamera(const Eigen::Matrix4d& transform_matrix, double fl_x, double fl_y, double cx, double cy,
                           const Eigen::Vector3d& point_world, Eigen::Vector2d* pixel);

// --- Preview bake + glTF ------------------------------------------------------

struct BakedTexture {
  int resolution_px = 0;
  Image linear;        // RGB, linear radiance; row 0 = v 1 (OBJ v up)
  Image weight;        // 1 channel: summed view weight per texel (0 = filled by push-pull)
  Image inside;        // 1 channel: 1 where a triangle covers the texel centre
  std::vector<Camera> views;
  double render_seconds = 0, accumulate_seconds = 0;
};

// The bake's light: a constant white environment of radiance
// bake_environment_radiance x the asset's cue light unit.
CueLight UniformWhiteLight(const AssetDescription& asset, const InteropOptions& options);

// Cameras on the upper hemisphere around `centre` (equal-area spiral between
// 5 and 80 degrees elevation), looking at it from `distance_m`.
std::vector<Camera> BakeViews(const Intrinsics& intrinsics, const Eigen::Vector3d& centre, double distance_m,
                              int count);

// A texel counts as seen when its summed view weight (cosine x coverage)
// reaches this; others are filled by push-pull.
constexpr float kSeenWeight = 1e-3f;

// Unwraps renders of `views` (render_view(i): premultiplied linear RGBA of
// views[i]) into the UV atlas of `mesh` at `resolution` (power of two).
// Every texel whose centre lies on a triangle is projected into each view,
// tested for visibility by an Embree ray against the mesh, and its colour
// averaged with weight cos(normal, view) x coverage over pixels the object
// covers (coverage >= 0.9, cosine >= 0.05); unseen texels are
// filled by push-pull. Progress bar with ETA (one step per view).
BakedTexture UnwrapViews(const render::TriangleMesh& mesh, int resolution, const std::vector<Camera>& views,
                         const std::function<Image(size_t view)>& render_view);

// Renders `renderer` under a uniform white environment from BakeViews and
// unwraps the renders into the UV atlas of `mesh` (the proxy): every texel's
// surface point is projected into each view, tested for visibility by an
// Embree ray, weighted by cos(normal, view) x coverage; unseen texels are
// filled by push-pull. Progress bar with ETA.
// `samples_per_pixel` replaces options.bake_samples_per_pixel when that is 0.
BakedTexture BakePreviewTexture(RelitRenderer& renderer, const render::TriangleMesh& mesh,
                                const InteropOptions& options, int cue_samples_per_pixel);

// Bilinear lookup of an RGB texture at OBJ uv (v up), clamped to the border.
Eigen::Vector3f SampleTexture(const Image& texture, const Eigen::Vector2f& uv);

// 8-bit sRGB RGBA image of the bake (alpha 255).
Image TonemapToSrgb(const BakedTexture& bake, double exposure);

// Writes a binary glTF 2.0 file: the mesh (positions and normals in the
// world frame, a root node rotation turning relit's +Z up into glTF's +Y up,
// UVs flipped to glTF's v-down), a material with the texture as base colour
// (KHR_materials_unlit: the bake already holds the shading): the bytes of
// the PNG file `texture_png`, embedded in the binary chunk. Written
// atomically.
void WriteGlb(const std::string& path, const render::TriangleMesh& mesh, const std::string& texture_png);

// --- Helpers shared by the exporters -------------------------------------------

// W/calib/cameras.json; throws naming the stage to run when it is missing.
CamerasFile ReadCalibCameras(const std::string& workspace);
// Hard-links `from` to `to` when `link` and the file system allows it,
// copies otherwise. Returns 1 when linked, 0 when copied.
int LinkOrCopyFile(const std::string& from, const std::string& to, bool link);

// --- All of it -----------------------------------------------------------------

// Writes `out_dir` (normally <asset>/interop): colmap/, nerf/, gltf/ and a
// README.md, each folder atomically, and records what was written in
// `record` (field "interop"). Needs a trained workspace (as ExportAsset).
void ExportInterop(const std::string& workspace, const std::string& out_dir, const InteropOptions& options,
                   RunRecord& record, ModelSet models = ModelSet::kFinal);

// The pieces, for tests and reuse. Each returns the JSON summary recorded.
nlohmann::json ExportColmap(const std::string& workspace, const std::string& out_dir, const InteropOptions& options,
                            const BakedTexture* bake);
nlohmann::json ExportNerf(const std::string& workspace, const std::string& out_dir, const InteropOptions& options);
nlohmann::json ExportGltf(const std::string& workspace, const std::string& out_dir, const InteropOptions& options,
                          BakedTexture* bake_out, ModelSet models = ModelSet::kFinal);

}  // namespace relit::relight
