#include "pipeline/selection.h"

#include <algorithm>
#include <map>
#include <set>

#include "core/error.h"

namespace relit::pipeline {

namespace {

// The step graph at the level of kinds (steps.cc builds the same edges per
// step; the train steps only exist once plan ran, so selections are decided
// on kinds).
const std::map<std::string, std::vector<std::string>>& KindDeps() {
  static const std::map<std::string, std::vector<std::string>> kDeps = {
      {"capture", {}},
      {"calib", {"capture"}},
      {"reconstruct", {"calib"}},
      {"cues", {"calib", "reconstruct"}},
      {"plan", {"calib", "reconstruct"}},
      {"train", {"calib", "reconstruct", "cues", "plan"}},
      {"augment", {"calib", "reconstruct", "cues", "plan", "train"}},
      {"render", {"calib", "reconstruct", "plan", "train", "augment"}},
      {"export", {"reconstruct", "plan", "train", "augment"}},
      {"eval", {"calib", "reconstruct", "cues", "plan", "train", "augment"}},
      {"report", {"capture", "calib", "reconstruct", "cues", "plan", "train", "augment", "render", "export", "eval"}}};
  return kDeps;
}

// The kinds a selector names.
std::vector<std::string> KindsOf(const std::string& selector) {
  if (selector == "relight") return {"cues", "plan", "train", "augment", "render", "export", "eval"};
  if (selector.rfind("train-", 0) == 0) return {"train"};
  if (selector.rfind("augment-", 0) == 0) return {"augment"};
  return {selector};
}

bool Contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

}  // namespace

std::vector<std::string> UpstreamKinds(const std::string& kind) {
  std::set<std::string> found;
  std::vector<std::string> stack = {kind};
  while (!stack.empty()) {
    const std::string k = stack.back();
    stack.pop_back();
    for (const std::string& d : KindDeps().at(k)) {
      if (found.insert(d).second) stack.push_back(d);
    }
  }
  return {found.begin(), found.end()};
}

std::vector<std::string> DownstreamKinds(const std::string& kind) {
  std::vector<std::string> result;
  for (const auto& [k, deps] : KindDeps()) {
    if (Contains(UpstreamKinds(k), kind)) result.push_back(k);
  }
  return result;
}

Selection::Selection(std::vector<std::string> only, std::vector<std::string> from,
                     std::vector<std::string> to, std::vector<std::string> force)
    : only_(std::move(only)), from_(std::move(from)), to_(std::move(to)), force_(std::move(force)) {
  for (const auto* list : {&only_, &from_, &to_, &force_}) {
    for (const std::string& s : *list) {
      RELIT_REQUIRE(IsKnownSelector(s), "unknown step '", s,
                    "': use capture, calib, reconstruct, cues, plan, train (or train-KK for one "
                    "partition), render, export, report, or relight for all relight steps");
    }
  }
  // --from F --to T runs the steps between them: T must not come before F.
  for (const std::string& f : from_) {
    for (const std::string& t : to_) {
      bool overlap = false;
      for (const std::string& fk : KindsOf(f)) {
        std::vector<std::string> after = DownstreamKinds(fk);
        after.push_back(fk);
        for (const std::string& tk : KindsOf(t)) {
          std::vector<std::string> before = UpstreamKinds(tk);
          before.push_back(tk);
          for (const std::string& k : after) overlap = overlap || Contains(before, k);
        }
      }
      RELIT_REQUIRE(overlap, "--from ", f, " --to ", t, " selects no step: ", t, " does not come after ", f,
                    " in the pipeline (capture, calib, reconstruct, cues, plan, train, augment, render, "
                    "export, eval, report); swap them or drop one");
    }
  }
}

std::vector<std::string> Selection::Selectors() const {
  std::vector<std::string> all;
  for (const auto* list : {&only_, &from_, &to_, &force_}) all.insert(all.end(), list->begin(), list->end());
  return all;
}

bool Selection::Selected(const Step& step) const {
  auto any = [&](const std::vector<std::string>& selectors, auto&& test) {
    return std::any_of(selectors.begin(), selectors.end(), test);
  };
  if (!only_.empty() && !any(only_, [&](const std::string& s) { return SelectorMatches(s, step); })) {
    return false;
  }
  // A selector of `selectors` names the step, or a kind whose `linked`
  // kinds (downstream for --from, upstream for --to) hold the step's kind.
  auto reaches = [&](const std::vector<std::string>& selectors, auto&& linked) {
    return any(selectors, [&](const std::string& s) {
      if (SelectorMatches(s, step)) return true;
      for (const std::string& k : KindsOf(s)) {
        if (Contains(linked(k), step.kind)) return true;
      }
      return false;
    });
  };
  if (!from_.empty() && !reaches(from_, DownstreamKinds)) return false;
  return to_.empty() || reaches(to_, UpstreamKinds);
}

bool Selection::Forced(const Step& step) const {
  for (const std::string& s : force_) {
    if (SelectorMatches(s, step)) return true;
  }
  return !from_.empty() && Selected(step);
}

}  // namespace relit::pipeline
