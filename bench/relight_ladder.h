// The input ladder of issue 24 (docs/relight.md, "Error budget"): the
// relight stage trained and scored on one synthetic capture four times, each
// rung taking one more input from the pipeline instead of the ground truth:
//   a  true cameras, lenses and flash positions, true mesh, true mattes
//   b  calibrated cameras and flash (calib), true mesh, true mattes
//   c  calibrated, the reconstruct stage's proxy, true mattes
//   d  calibrated, the stage's proxy and its own mattes (the whole pipeline)
// (and, on request, o: rung b with the true mesh moved out by a few tenths of
// a millimetre: what proxy accuracy the relight stage needs),
// so that what a stage costs is the difference between two neighbouring rungs.
// This file builds the rungs' workspaces from a pipeline workspace (capture,
// calib and reconstruct done) and the synthetic capture's truth.json; the
// bench (relight_ladder_main.cc) runs the relight steps in each.
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "core/render/mesh.h"

namespace relit::bench {

// The rungs run by default, in order.
inline const char* const kLadderRungs = "abcd";
// Every rung, in table order: rung (o) is rung (b) with the true mesh moved
// outward by a given distance (--offset-mm), the proxy accuracy a dB costs.
inline const char* const kAllLadderRungs = "abcdo";
// One line saying what rung `rung` takes from the truth and from the pipeline
// (`offset_mm`: rung o's offset).
std::string RungDescription(char rung, double offset_mm = 1.0);

// Copies the tree `from` to `to` as hard links (a plain copy across file
// systems). The rungs only read what they link: every file a rung writes
// is written under a new name and renamed, so the source stays untouched.
void LinkTree(const std::filesystem::path& from, const std::filesystem::path& to);

// Writes `rung_workspace`/calib from `source_workspace`/calib with the
// truth put in: every registered frame's pose, the phones' lenses (scaled to
// the capture's frame size), the flash positions of the phone V frames
// lights.json lists (all reliable), and the phone V frames undistorted
// again from capture/ with the true lens into the same pinhole camera.
// Geometry-pass frames are left out: a reconstruct given the mesh and the
// relight stage do not read them. Needs `rung_workspace`/capture.
void WriteTruthCalib(const std::filesystem::path& source_workspace, const nlohmann::json& truth,
                     const std::filesystem::path& rung_workspace);

// Replaces every matte that `rung_workspace`/reconstruct/proxy.json lists by
// the truth's alpha of that frame (truth/view_alpha, rendered through the
// true lens), resampled with the rung's own undistortion (its cameras.json
// lens into its pinhole camera), exactly as calib resampled the frame. The
// files are written under new names and renamed. Returns how many.
int WriteTruthMattes(const std::filesystem::path& rung_workspace, const std::filesystem::path& synth_dir,
                     const nlohmann::json& truth);

// The truth's object meshes as one file for `relit-reconstruct --mesh`:
// the single object's own OBJ, or the objects merged into `work_dir`.
std::string TruthObjectMesh(const std::filesystem::path& synth_dir, const nlohmann::json& truth,
                            const std::filesystem::path& work_dir);

// `mesh` with every position moved `offset_m` along its vertex's
// area-weighted normal (negative: inward). Positions that are equal (a UV
// seam's copies) move together, so the surface does not tear. Normals are
// dropped (reconstruct computes its own).
render::TriangleMesh OffsetAlongNormals(const render::TriangleMesh& mesh, double offset_m);

// The truth's object mesh (TruthObjectMesh) moved by `offset_m`, written to
// `work_dir`/truth_objects_offset.obj for rung (o).
std::string OffsetTruthMesh(const std::filesystem::path& synth_dir, const nlohmann::json& truth,
                            double offset_m, const std::filesystem::path& work_dir);

// The `reconstruct:` options for the rungs on the true mesh (a, b, o): the
// pipeline's own with `normal_map.enabled: false`. The true mesh's normals
// are true; reconstruct's photometric normal map is an estimate, and what it
// costs or gains belongs to the stage's proxy (rung c).
YAML::Node TrueMeshReconstructOptions(const YAML::Node& reconstruct);

// What the ladder table shows of one rung's eval.json: PSNR per light type
// and "all" (all views and interpolation views) of the model, cue fit and
// cues-only; alpha MAE of the model and of the proxy's coverage (cues-only's
// alpha).
nlohmann::json RungScores(const nlohmann::json& eval);

// The Markdown table of the rungs' scores ({"a": RungScores, ...}) and the
// dB each stage costs (neighbouring rungs' model, interpolation views).
std::string LadderTable(const nlohmann::json& scores);

}  // namespace relit::bench
