// `relit-relight compare`: one Markdown table from several workspaces'
// evaluations (eval.json of `relit-relight eval`), so baselines trained by
// the same tool on the same data sit side by side with their training budget.
//
// Rows: every scored method of every eval.json, labelled with the model's
// input variant (eval.json "model_variant": dnl, dnl_1_basis, sh_dnr; files
// from before it existed count as dnl). Columns: each light type's
// "PSNR dB / MAE / SSIM" (eval.json "summary"), the training steps and the
// budget in CPU-hours: the sum of `process_cpu_s` of the workspace's
// train.json files (W/relight/partitions/KK/, plus W/relight/augment/KK/ for
// the final model of an augmented workspace). A train.json without
// process_cpu_s (older relit) shows its wall time instead, marked "wall".
// All evaluations must share the truth and eval.json "clip_radiance"
// (absent: 0, not clipped); the header names both.
#pragma once

#include <string>
#include <vector>

namespace relit {
class RunRecord;
}

namespace relit::relight {

struct CompareInput {
  std::string eval_dir;  // holds eval.json
  std::string label;     // optional prefix of the rows ("" = the folder name)
};

// The Markdown table (with a header line naming the truth and the notes).
// Throws relit::Error naming a missing or malformed eval.json.
std::string CompareEvaluations(const std::vector<CompareInput>& inputs);

// Parses "LABEL=DIR" or "DIR".
CompareInput ParseCompareInput(const std::string& text);

}  // namespace relit::relight
