// Ground truth of a synthetic capture: truth.json (schema relit.synth_truth/1)
// and the files it references (world-frame meshes, material textures, the
// printed board). Paths inside truth.json are relative to the output directory.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "tools/synth/capture_plan.h"
#include "tools/synth/scene.h"
#include "tools/synth/synth_options.h"

namespace relit::synth {

constexpr const char* kTruthKind = "synth_truth";
constexpr int kTruthVersion = 1;

// Relative paths of per-frame and per-view files, shared by the renderer and
// the truth writer.
std::string AlphaPath(const std::string& video, int frame);   // truth/<video>_alpha/NNNNNN.exr
std::string BoardClipFolder(const std::string& phone);          // board_clip/<phone>
std::string BoardClipFramePath(const std::string& phone, int frame);  // board_clip/<phone>/NNNNNN.png
std::string EvalImagePath(const std::string& view, const std::string& light);  // eval/<view>/<light>.exr
std::string EvalTwinImagePath(const std::string& view, const std::string& light);  // eval/<view>/<light>.twin.exr
std::string EvalHalfImagePath(const std::string& view, const std::string& light);  // eval/<view>/<light>.half.exr
std::string EvalAlphaPath(const std::string& view);           // eval/<view>/alpha.exr
std::string EnvmapPath(const std::string& name);              // eval/envmaps/<name>.exr
std::string MeshPath(const std::string& object);              // truth/meshes/<object>.obj
std::string TexturePath(const std::string& texture);          // truth/textures/<texture>.exr
constexpr const char* kGeometryEnvmapPath = "truth/geometry_environment.exr";
constexpr const char* kBoardImagePath = "truth/board.png";

// Writes meshes, textures and the board image below `out_dir`.
void WriteSceneTruth(const SynthScene& scene, const std::string& out_dir);

// What a run rendered: a full run both, an eval_only run the evaluation set,
// a truth_only run nothing. The plan (cameras, lights, paths) is the same.
struct RenderedParts {
  bool videos = false;  // the videos and the phone-V / geometry alpha mattes
  bool eval = false;    // eval/: held-out views x lights, their alpha, the envmaps
};

// The truth.json body (without "schema"). "rendered" says whether the
// evaluation images exist (what relit-relight eval checks), "videos_rendered"
// whether the videos and the per-frame "alpha" files they list exist.
nlohmann::json MakeTruthJson(const SynthOptions& options, const SynthScene& scene,
                             const CapturePlan& plan, RenderedParts rendered);

}  // namespace relit::synth
