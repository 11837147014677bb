// Checks the stage sections of pipeline.yaml with the stages' own option
// readers, so a typo in `calib.detect.min_corner` is reported as
// "pipeline.yaml:31: unknown key 'calib.detect.min_corner'" before any step
// runs, not as an error of a generated per-step file an hour later.
//
// The relight stage links LibTorch; the orchestrator does not, so for
// `relight:` only the top-level keys of the relight contract are checked here
// and relit-relight checks the rest when its first step starts.
#include <set>

#include "calib/calib_options.h"
#include "capture/capture_options.h"
#include "core/error.h"
#include "pipeline/config.h"
#include "reconstruct/reconstruct_options.h"

namespace relit::pipeline::internal {

namespace {

// Keys that relit sets itself from inputs:/board:; writing them in a stage
// section would be silently overridden, so it is an error.
void RejectOwnedKey(OptionsReader& section, const std::string& key, const std::string& instead) {
  RELIT_REQUIRE(!section.Has(key), section.Where(key), ": relit sets '",
                section.context(), ".", key, "' itself; set ", instead, " instead");
}

std::string Prefix(const PipelineConfig& config, const std::string& section) {
  return config.file + ": " + section + ": ";
}

}  // namespace

void CheckStageSections(const PipelineConfig& config, const YAML::Node& root) {
  OptionsReader reader(root, config.file);

  {
    OptionsReader section = reader.Child("capture");
    RejectOwnedKey(section, "view", "inputs.view");
    RejectOwnedKey(section, "light", "inputs.light");
    RejectOwnedKey(section, "geometry", "inputs.geometry");
    RejectOwnedKey(section, "out", "the workspace (relit run --workspace W)");
    capture::CaptureOptions options;
    options.Read(section);
    options.view = config.view;
    options.light = config.light;
    options.out = "capture";
    try {
      options.Check();
    } catch (const Error& e) {
      Fail(Prefix(config, "capture"), e.what());
    }
  }
  {
    OptionsReader section = reader.Child("calib");
    RejectOwnedKey(section, "workspace", "the workspace (relit run --workspace W)");
    RejectOwnedKey(section, "board", "the top-level board: section");
    if (section.Has("intrinsics")) {
      OptionsReader intrinsics = section.Child("intrinsics");
      RejectOwnedKey(intrinsics, "view_board_images", "inputs.board_view_images");
      RejectOwnedKey(intrinsics, "light_board_images", "inputs.board_light_images");
    }
    calib::CalibOptions options;
    options.Read(section);
    options.workspace = "W";
    OptionsReader board = reader.Child("board");
    ReadBoardSpec(board, &options.board);
    try {
      options.Check();
    } catch (const Error& e) {
      Fail(Prefix(config, "calib"), e.what());
    }
  }
  {
    OptionsReader section = reader.Child("reconstruct");
    RejectOwnedKey(section, "workspace", "the workspace (relit run --workspace W)");
    RejectOwnedKey(section, "mesh", "inputs.proxy_mesh");
    reconstruct::ReconstructOptions options;
    options.Read(section);
    options.workspace = "W";
    try {
      options.Check();
    } catch (const Error& e) {
      Fail(Prefix(config, "reconstruct"), e.what());
    }
  }
  {
    // The relight contract: the file holds these sections; each sub-step reads
    // all of them.
    OptionsReader section = reader.Child("relight");
    for (const char* key : {"cues", "dataset", "partitions", "model", "train", "augment", "render", "export", "eval"}) {
      if (section.Has(key)) {
        section.Child(key);  // must be a mapping; its keys are relit-relight's to check
      } else {
        section.Ignore(key);
      }
    }
    std::string log_level;
    section.Read("log_level", &log_level);
    // Finish() would also walk the children opened above, whose keys only
    // relit-relight knows; check the top level by hand.
    const YAML::Node& node = config.relight;
    if (node.IsMap()) {
      const std::set<std::string> known = {"cues",   "dataset", "partitions", "model", "train",
                                           "augment", "render", "export",    "eval",  "log_level"};
      for (const auto& entry : node) {
        const std::string key = entry.first.as<std::string>();
        RELIT_REQUIRE(known.count(key), config.file, ":", entry.first.Mark().line + 1,
                      ": unknown key 'relight.", key,
                      "' (known keys: augment, cues, dataset, eval, export, log_level, model, partitions, render, train)");
      }
    }
  }
}

}  // namespace relit::pipeline::internal
