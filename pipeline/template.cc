// The pipeline.yaml template written by `relit init` (docs/pipeline.md has
// the same keys with more words). Keys left commented out keep the stage's
// default; pipeline_config_test checks that the template parses.
#include "pipeline/config.h"

namespace relit::pipeline {

std::string PipelineTemplate() {
  return R"yaml(# relit pipeline for one capture. Run it with
#   relit run pipeline.yaml --workspace WORKSPACE
# and see what is up to date with `relit status pipeline.yaml --workspace WORKSPACE`.
# Paths are relative to this file's folder. Unknown keys are errors.
# Every key is explained in docs/pipeline.md.

inputs:
  view: view.mp4              # phone V: films without flash (the camera)
  light: light.mp4            # phone L: films with its flash on (the moving light)
  # geometry: geometry.mp4    # optional geometry pass: a video or a folder of photos
  # board_view_images: board_view/    # optional board clip frames of phone V (fixes its lens)
  # board_light_images: board_light/  # same for phone L
  # proxy_mesh: scan.obj      # optional proxy mesh (OBJ/PLY, board frame, metres) for reconstruct

# The printed ChArUco board (measure the printed squares with a ruler).
board:
  squares_x: 7                # squares along the printed rows
  squares_y: 5                # squares down the page (odd)
  square_length_m: 0.040
  marker_length_m: 0.030
  dictionary: DICT_APRILTAG_36h11

# Where the stage executables are; by default relit looks next to itself
# (the build tree), in $RELIT_BIN_DIR, then on PATH.
# tools:
#   capture: /opt/relit/bin/relit-capture
#   calib: ...
#   reconstruct: ...
#   relight: ...
#   report: ...

run:
  jobs: 1                     # local steps at once (training partitions run in parallel)
  executor: local             # local | slurm
  export: auto                # auto (when relit-relight has export) | on | off

# Used with run.executor: slurm (see docs/pipeline.md, "Running on a cluster").
# The workspace must be on a filesystem every node mounts at the same path.
# slurm:
#   steps: [cues, train]      # step kinds submitted with sbatch; the rest runs here
#   poll_s: 10                # squeue polling interval
#   resources:                # sbatch resources of every submitted step
#     partition: ""
#     account: ""
#     cpus: 8
#     memory: 16G
#     gpus: 0
#     time: "04:00:00"
#     extra_args: []          # more sbatch arguments, e.g. ["--qos=normal"]
#   train: {gpus: 1, time: "12:00:00"}   # per step kind, over resources

# Stage options: docs/capture.md, docs/calib.md, docs/reconstruct.md,
# docs/relight.md. An empty section keeps every default.
capture:
  # view_select: {target_frames: 150}
  # transfer: auto

calib:
  # sfm: {enabled: true}

reconstruct:
  # atlas: {resolution_px: 1024}

relight:
  # partitions: {layout: dnl13}   # single | dnl13 | ...

report:
)yaml";
}

}  // namespace relit::pipeline
