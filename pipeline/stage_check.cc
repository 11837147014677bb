// Checks the stage sections of pipeline.yaml with the stages' own option
// readers, so a typo in `calib.detect.min_corner` is reported as
// "pipeline.yaml:31: unknown key 'calib.detect.min_corner'" before any step
// runs, not as an error of a generated per-step file an hour later.
//
// The relight stage links LibTorch; the orchestrator does not: relight's
// option readers live in relit_relight_data (relight/relight_options.cc), so
// `relight:` is checked to the last key here too.
#include "calib/calib_options.h"
#include "capture/capture_options.h"
#include "core/error.h"
#include "pipeline/config.h"
#include "reconstruct/reconstruct_options.h"
#include "relight/relight_options.h"

namespace relit::pipeline::internal {

namespace {

// Keys that relit sets itself from inputs:/board:; writing them in a stage
// section would be silently overridden, so it is an error.
void RejectOwnedKey(OptionsReader& section, const std::string& key, const std::string& instead) {
  RELIT_REQUIRE(!section.Has(key), section.Where(key), ": relit sets '",
                section.context(), ".", key, "' itself; set ", instead, " instead");
}

// The options of a stage that works in the run's workspace, read from its
// section; the workspace is a placeholder (the run passes its own).
template <typename S>
S ReadWorkspaceStageSection(OptionsReader& section) {
  S options;
  ReadOptions(section, &options);
  options.workspace = "W";
  return options;
}

std::string Prefix(const PipelineConfig& config, const std::string& section) {
  return config.file + ": " + section + ": ";
}

// CheckOptions with the file and section in front of a value error (reader
// errors already start with the file and line).
template <typename S>
void CheckSection(const PipelineConfig& config, const std::string& section, const S& options) {
  try {
    CheckOptions(options);
  } catch (const Error& e) {
    Fail(Prefix(config, section), e.what());
  }
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
    ReadOptions(section, &options);
    options.view = config.view;
    options.light = config.light;
    options.out = "capture";
    CheckSection(config, "capture", options);
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
    calib::CalibOptions options = ReadWorkspaceStageSection<calib::CalibOptions>(section);
    OptionsReader board = reader.Child("board");
    ReadBoardSpec(board, &options.board);
    CheckSection(config, "calib", options);
  }
  {
    OptionsReader section = reader.Child("reconstruct");
    RejectOwnedKey(section, "workspace", "the workspace (relit run --workspace W)");
    RejectOwnedKey(section, "mesh", "inputs.proxy_mesh");
    CheckSection(config, "reconstruct", ReadWorkspaceStageSection<reconstruct::ReconstructOptions>(section));
  }
  {
    // The whole relight section, with relit-relight's own readers (no
    // LibTorch: relit_relight_data), so `relight: {train: {stesp: 10}}` fails
    // here, not when the train step starts.
    OptionsReader section = reader.Child("relight");
    try {
      relight::CheckRelightSection(section);
    } catch (const Error& e) {
      const std::string message = e.what();
      // Reader errors already start with "pipeline.yaml:LINE"; value checks
      // get the file and section in front.
      if (message.rfind(config.file, 0) == 0) throw;
      Fail(Prefix(config, "relight"), message);
    }
  }
}

}  // namespace relit::pipeline::internal
