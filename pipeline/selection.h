// Which steps a `relit run` touches: --only, --from, --to and --force take
// step names ("calib", "train-03") or groups ("train": every partition,
// "relight": cues, plan, train, render, export).
#pragma once

#include <string>
#include <vector>

#include "pipeline/steps.h"

namespace relit::pipeline {

class Selection {
 public:
  // Throws relit::Error for a selector that names no step.
  Selection(std::vector<std::string> only, std::vector<std::string> from,
            std::vector<std::string> to, std::vector<std::string> force);

  // Whether the run considers this step at all (others are left as they are).
  bool Selected(const Step& step) const;
  // Whether it runs even when up to date (--force, and --from's steps).
  bool Forced(const Step& step) const;
  bool empty() const { return only_.empty() && from_.empty() && to_.empty(); }
  // Every selector given (--only, --from, --to, --force).
  std::vector<std::string> Selectors() const;

 private:
  std::vector<std::string> only_, from_, to_, force_;
};

// Step kinds that `kind` reads from, directly or not ("train" -> capture,
// calib, reconstruct, cues, plan), and the kinds that read from it.
std::vector<std::string> UpstreamKinds(const std::string& kind);
std::vector<std::string> DownstreamKinds(const std::string& kind);

}  // namespace relit::pipeline
