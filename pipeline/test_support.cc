#include "pipeline/test_support.h"

#include <unistd.h>

#include <atomic>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

namespace relit::pipeline::testing {

namespace fs = std::filesystem;

namespace {

// Shared by every script: argument lookup, the calls file, deliberate
// failures and an atomic publish of the output folder.
const char* kCommon = R"sh(#!/bin/bash
set -euo pipefail
args=("$@")
get() {
  local i
  for ((i = 0; i < ${#args[@]}; i++)); do
    if [ "${args[$i]}" = "$1" ]; then echo "${args[$((i + 1))]}"; return; fi
  done
}
note() {
  echo "$1" >>"${RELIT_TEST_CALLS:-/dev/null}"
  if [ "${RELIT_TEST_FAIL:-}" = "$1" ]; then echo "failing on purpose: $1" >&2; exit 3; fi
}
digest() { cat "$@" | sha256sum | cut -d' ' -f1; }
publish() {  # publish TMP DEST: replace DEST by TMP in one rename
  rm -rf "$2.old"
  if [ -e "$2" ]; then mv "$2" "$2.old"; fi
  mv "$1" "$2"
  rm -rf "$2.old"
}
W=$(get --workspace)
cfg=$(get --config)
)sh";

const char* kCapture = R"sh(note capture
out=$(get --out)
mkdir -p "$out.tmp.$$"
digest "$(get --view)" "$(get --light)" "$cfg" >"$out.tmp.$$/capture.txt"
publish "$out.tmp.$$" "$out"
)sh";

const char* kCalib = R"sh(note calib
mkdir -p "$W/calib.tmp.$$"
digest "$W/capture/capture.txt" "$cfg" >"$W/calib.tmp.$$/calib.txt"
publish "$W/calib.tmp.$$" "$W/calib"
)sh";

const char* kReconstruct = R"sh(note reconstruct
mesh=$(get --mesh)
mkdir -p "$W/reconstruct.tmp.$$"
digest "$W/calib/calib.txt" "$cfg" ${mesh:+"$mesh"} >"$W/reconstruct.tmp.$$/proxy.txt"
publish "$W/reconstruct.tmp.$$" "$W/reconstruct"
)sh";

const char* kRelight = R"sh(sub=$1
case "$sub" in
  --help)
    printf 'relit-relight (test stand-in)\nSUBCOMMANDS:\n  cues  c\n  plan  p\n  train  t\n  render  r\n'
    if [ -n "${RELIT_TEST_EXPORT:-}" ]; then printf '  export  e\n'; fi
    ;;
  export)
    note export
    mkdir -p "$W/relight/export.tmp.$$"
    digest "$W"/relight/partitions/*/train.json >"$W/relight/export.tmp.$$/manifest.json"
    publish "$W/relight/export.tmp.$$" "$W/relight/export"
    ;;
  cues)
    note cues
    mkdir -p "$W/relight/cues.tmp.$$"
    digest "$W/calib/calib.txt" "$W/reconstruct/proxy.txt" "$cfg" >"$W/relight/cues.tmp.$$/cues.txt"
    publish "$W/relight/cues.tmp.$$" "$W/relight/cues"
    ;;
  plan)
    note plan
    n=$(sed -n 's/.*holdout_every: *\([0-9][0-9]*\).*/\1/p' "$cfg" | head -n 1)
    n=${n:-3}
    mkdir -p "$W/relight/plan.tmp.$$"
    {
      printf '{"schema": "relit.relight_plan/1", "partitions": ['
      for ((k = 0; k < n; k++)); do
        [ "$k" -gt 0 ] && printf ', '
        printf '{"index": %d, "direction": [0, 0, 1], "train_frames": [], "validation_frames": []}' "$k"
      done
      printf '], "layout": {"count": %d}}\n' "$n"
    } >"$W/relight/plan.tmp.$$/plan.json"
    publish "$W/relight/plan.tmp.$$" "$W/relight/plan"
    ;;
  train)
    k=$(get --partition)
    name=train-$(printf '%02d' "$k")
    note "$name"
    out="$W/relight/partitions/$(printf '%02d' "$k")"
    mkdir -p "$out"
    echo "$name start $(date +%s.%N)" >>"${RELIT_TEST_TIMES:-/dev/null}"
    # Like a training loop: work in progress lands in the output folder
    # (checkpoints) long before the final record.
    echo "checkpoint of $name" >"$out/checkpoint.txt"
    if [ -n "${RELIT_TEST_TRAIN_MARK:-}" ]; then touch "$RELIT_TEST_TRAIN_MARK/$name.started"; fi
    echo "train $name: step 1/2"
    sleep "${RELIT_TEST_SLEEP_S:-0}"
    echo "train $name: step 2/2"
    digest "$W/relight/cues/cues.txt" "$W/relight/plan/plan.json" "$cfg" <(echo "$k") >"$out/train.json"
    echo "$name end $(date +%s.%N)" >>"${RELIT_TEST_TIMES:-/dev/null}"
    ;;
  render)
    note render
    mkdir -p "$W/relight/render.tmp.$$"
    digest "$W"/relight/partitions/*/train.json "$cfg" >"$W/relight/render.tmp.$$/render.json"
    publish "$W/relight/render.tmp.$$" "$W/relight/render"
    ;;
  *)
    echo "unknown subcommand $sub" >&2
    exit 2
    ;;
esac
)sh";

const char* kReport = R"sh(note report
mkdir -p "$W/report.tmp.$$"
find "$W/capture" "$W/calib" "$W/reconstruct" "$W/relight" -type f -not -name '*.tmp*' | sort |
  xargs cat | sha256sum >"$W/report.tmp.$$/index.html"
publish "$W/report.tmp.$$" "$W/report"
)sh";

void WriteScript(const fs::path& path, const std::string& body) {
  WriteText(path, std::string(kCommon) + body);
  fs::permissions(path, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                            fs::perms::others_read | fs::perms::others_exec);
}

}  // namespace

TempDir::TempDir() {
  static std::atomic<int> counter{0};
  path_ = fs::temp_directory_path() /
          ("relit_pipeline_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  fs::remove_all(path_);
  fs::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code error;
  fs::remove_all(path_, error);
}

void WriteText(const fs::path& path, const std::string& text) {
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << "cannot write " << path;
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void WriteStageScripts(const fs::path& bin_dir) {
  fs::create_directories(bin_dir);
  WriteScript(bin_dir / "relit-capture", kCapture);
  WriteScript(bin_dir / "relit-calib", kCalib);
  WriteScript(bin_dir / "relit-reconstruct", kReconstruct);
  WriteScript(bin_dir / "relit-relight", kRelight);
  WriteScript(bin_dir / "relit-report", kReport);
}

fs::path WriteScriptPipeline(const fs::path& dir, const fs::path& bin_dir, const std::string& extra) {
  WriteText(dir / "capture" / "view.mp4", "phone V video bytes\n");
  WriteText(dir / "capture" / "light.mp4", "phone L video bytes\n");
  const fs::path yaml = dir / "pipeline.yaml";
  std::string text = "inputs:\n  view: capture/view.mp4\n  light: capture/light.mp4\n"
                     "board: {dictionary: DICT_4X4_50}\n"
                     "tools:\n";
  for (const char* stage : {"capture", "calib", "reconstruct", "relight", "report"}) {
    text += std::string("  ") + stage + ": " + (bin_dir / ("relit-" + std::string(stage))).string() + "\n";
  }
  WriteText(yaml, text + extra);
  return yaml;
}

std::vector<std::string> CalledSteps(const fs::path& calls_file) {
  std::vector<std::string> steps;
  std::istringstream in(ReadText(calls_file));
  for (std::string line; std::getline(in, line);) {
    if (!line.empty()) steps.push_back(line);
  }
  return steps;
}

}  // namespace relit::pipeline::testing
