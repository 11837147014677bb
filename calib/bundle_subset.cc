#include "calib/bundle_subset.h"

#include <algorithm>
#include <chrono>

#include <spdlog/spdlog.h>

#include "core/run_record.h"

namespace relit::calib {

std::vector<bool> ChooseKeyFrames(const BundleProblem& problem, int max_frames) {
  std::vector<size_t> posed;
  for (size_t f = 0; f < problem.frames.size(); ++f) {
    if (problem.frames[f].posed) posed.push_back(f);
  }
  std::vector<bool> key(problem.frames.size(), false);
  if (max_frames <= 0 || static_cast<int>(posed.size()) <= max_frames) {
    for (size_t f : posed) key[f] = true;
    return key;
  }
  // Frame k of n is taken when floor(k * max / n) steps up: exactly max
  // frames, spread evenly.
  for (size_t k = 0; k < posed.size(); ++k) {
    if (k == 0 || (k * max_frames) / posed.size() != ((k - 1) * max_frames) / posed.size()) key[posed[k]] = true;
  }
  return key;
}

namespace {

// The frames not in `key` placed one by one (one Ceres problem: its
// frames share no parameter) with the lenses and the points of the key
// solve held. Points seen by fewer than two key frames were not refined:
// they are left out.
BundleStats PlaceOtherFrames(BundleProblem* problem, const BundleOptions& options, const std::vector<bool>& key) {
  BundleProblem place = *problem;
  for (const auto& [device, lens] : place.devices) place.fixed_lens[device] = true;
  place.fixed_points = true;
  for (size_t f = 0; f < key.size(); ++f) {
    if (key[f]) place.frames[f].posed = false;
  }
  place.points.erase(std::remove_if(place.points.begin(), place.points.end(),
                                    [&key](const BundlePoint& point) {
                                      int key_observations = 0;
                                      for (const PointObservation& obs : point.observations) {
                                        key_observations += key[obs.frame];
                                      }
                                      return key_observations < 2;
                                    }),
                     place.points.end());
  BundleOptions o = options;
  o.rolling_shutter = false;  // RefineBundleOnKeyFrames takes every frame when it is on
  const BundleStats stats = RefineBundle(&place, o);
  for (size_t f = 0; f < key.size(); ++f) {
    if (key[f]) continue;
    problem->frames[f].posed = place.frames[f].posed;
    problem->frames[f].cam_from_world = place.frames[f].cam_from_world;
  }
  return stats;
}

}  // namespace

BundleStats RefineBundleOnKeyFrames(BundleProblem* problem, const BundleOptions& options, int max_frames,
                                    SubsetStats* subset) {
  const auto start = std::chrono::steady_clock::now();
  // The rolling shutter's motion model reads each frame's neighbours: a
  // subset would change it, so it takes every frame.
  const std::vector<bool> key = ChooseKeyFrames(*problem, options.rolling_shutter ? 0 : max_frames);
  int posed = 0, keys = 0;
  for (size_t f = 0; f < key.size(); ++f) {
    posed += problem->frames[f].posed;
    keys += key[f];
  }
  *subset = SubsetStats();
  subset->key_frames = keys;
  if (keys == posed) {
    BundleStats stats = RefineBundle(problem, options);
    subset->joint_s = SecondsSince(start);
    return stats;
  }
  spdlog::info("bundle: joint solve on {} key frames of {} (refine.max_joint_frames), then the other {} placed "
               "on its lenses and points", keys, posed, posed - keys);
  BundleProblem joint = *problem;
  for (size_t f = 0; f < key.size(); ++f) joint.frames[f].posed = key[f];
  const BundleStats joint_stats = RefineBundle(&joint, options);
  problem->devices = joint.devices;
  problem->points = joint.points;
  for (size_t f = 0; f < key.size(); ++f) {
    if (key[f]) problem->frames[f] = joint.frames[f];
  }
  subset->joint_s = SecondsSince(start);
  const auto placement_start = std::chrono::steady_clock::now();
  const BundleStats placed = PlaceOtherFrames(problem, options, key);
  subset->placement_s = SecondsSince(placement_start);
  for (size_t f = 0; f < key.size(); ++f) subset->placed_frames += !key[f] && problem->frames[f].posed;
  spdlog::info("bundle: {} of {} other frames placed ({} + {} iterations, {:.1f} s)", subset->placed_frames,
               posed - keys, placed.iterations - placed.final_iterations, placed.final_iterations,
               subset->placement_s);
  BundleStats stats = EvaluateBundle(*problem, options.outlier_px);
  stats.iterations = joint_stats.iterations;
  stats.final_iterations = joint_stats.final_iterations;
  stats.initial_cost = joint_stats.initial_cost;
  stats.final_cost = joint_stats.final_cost;
  stats.linear_solver = joint_stats.linear_solver;
  stats.dense_library = joint_stats.dense_library;
  stats.solve_s = SecondsSince(start);
  return stats;
}

}  // namespace relit::calib
