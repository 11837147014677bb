// `relit-relight plan`: which frames train which partition.
//
// Reads W/relight/cues/cues.json, W/calib/cameras.json (the undistorted
// linear images) and W/reconstruct/proxy.json (mattes, object centre);
// writes W/relight/plan/plan.json (schema relit.relight_plan/1):
//   layout          the partition layout (vertices, triangles)
//   object_centre_m view directions are measured from here
//   max_radiance    M of the log encoding, from the training targets
//   frames          [{name, cues, image, matte, direction, role}] with role
//                   "train" or "validation" (every dataset.holdout_every-th
//                   frame in time order)
//   partitions      [{index, direction, train_frames, validation_frames}]
// Every partition trains independently from this file alone.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/json_file.h"
#include "core/option_fields.h"
#include "relight/partitions.h"
#include "relight/stage_options.h"

namespace relit {
class RunRecord;
}

namespace relit::relight {

struct PlanFrame {
  std::string name;     // phone V frame, e.g. "view/000012"
  std::string cues;     // cue EXR, relative to the workspace
  std::string image;    // undistorted linear EXR (the target)
  std::string matte;    // 16-bit PNG matte
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  // object centre -> camera, unit
  Eigen::Vector3d light_position_m = Eigen::Vector3d::Zero();
  bool validation = false;
};

struct PlanPartition {
  int index = 0;
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
  std::vector<int> train_frames;       // indices into Plan::frames
  std::vector<int> validation_frames;
};

struct Plan : ObjectLayout {
  static constexpr const char* kKind = "relight_plan";
  static constexpr int kVersion = 1;
  double max_radiance = 0;
  int width_px = 0, height_px = 0;   // training image size
  std::vector<PlanFrame> frames;
  std::vector<PlanPartition> partitions;

  int FrameIndex(const std::string& name) const;  // -1 when absent
};

Plan ReadPlan(const std::string& path);
void WritePlan(const std::string& path, const Plan& plan);

// Builds the plan from the workspace (reads the target images for M).
Plan MakePlan(const std::string& workspace, const DatasetOptions& dataset,
              const PartitionLayoutOptions& layout);

void RunPlanStage(const std::string& workspace, const DatasetOptions& dataset,
                  const PartitionLayoutOptions& layout, RunRecord& record);

}  // namespace relit::relight
