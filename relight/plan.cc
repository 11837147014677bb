#include "relight/plan.h"

#include <algorithm>
#include <filesystem>

#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "core/workspace.h"
#include "core/stage_run.h"
#include "relight/cue_stage.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

int Plan::FrameIndex(const std::string& name) const {
  for (size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

Plan ReadPlan(const std::string& path) {
  RELIT_REQUIRE(fs::exists(path), path, " is missing: run `relit-relight plan` first");
  const json j = ReadJsonFile(path, Plan::kKind, Plan::kVersion);
  Plan plan;
  ReadObjectLayout(j, path, &plan);
  plan.max_radiance = JsonNumber(j, "max_radiance", path);
  plan.width_px = JsonInt(j, "width_px", path);
  plan.height_px = JsonInt(j, "height_px", path);
  for (const json& f : JsonField(j, "frames", path)) {
    const std::string where = path + ": frames[" + std::to_string(plan.frames.size()) + "]";
    PlanFrame frame;
    frame.name = JsonField(f, "name", where).get<std::string>();
    frame.cues = JsonField(f, "cues", where).get<std::string>();
    frame.image = JsonField(f, "image", where).get<std::string>();
    frame.matte = JsonField(f, "matte", where).get<std::string>();
    frame.direction = Vector3FromJson(JsonField(f, "direction", where), where);
    frame.light_position_m = Vector3FromJson(JsonField(f, "light_position_m", where), where);
    frame.validation = JsonField(f, "role", where).get<std::string>() == "validation";
    plan.frames.push_back(frame);
  }
  for (const json& p : JsonField(j, "partitions", path)) {
    PlanPartition partition;
    partition.index = JsonInt(p, "index", path);
    partition.direction = Vector3FromJson(JsonField(p, "direction", path), path);
    for (const char* key : {"train_frames", "validation_frames"}) {
      std::vector<int>& list = std::string(key) == "train_frames" ? partition.train_frames
                                                                  : partition.validation_frames;
      for (const json& name : JsonField(p, key, path)) {
        const int index = plan.FrameIndex(name.get<std::string>());
        RELIT_REQUIRE(index >= 0, path, ": partition ", partition.index, " names unknown frame ", name.dump());
        list.push_back(index);
      }
    }
    plan.partitions.push_back(partition);
  }
  return plan;
}

void WritePlan(const std::string& path, const Plan& plan) {
  const json frames = JsonList(plan.frames, [](const PlanFrame& f) {
    return json{{"name", f.name},
                {"cues", f.cues},
                {"image", f.image},
                {"matte", f.matte},
                {"direction", ToJson(f.direction)},
                {"light_position_m", ToJson(f.light_position_m)},
                {"role", f.validation ? "validation" : "train"}};
  });
  json partitions = json::array();
  for (const PlanPartition& p : plan.partitions) {
    json train = json::array(), validation = json::array();
    for (int i : p.train_frames) train.push_back(plan.frames[i].name);
    for (int i : p.validation_frames) validation.push_back(plan.frames[i].name);
    partitions.push_back({{"index", p.index},
                          {"direction", ToJson(p.direction)},
                          {"train_frames", train},
                          {"validation_frames", validation}});
  }
  json body = ObjectLayoutJson(plan);
  body.update({{"max_radiance", plan.max_radiance},
               {"width_px", plan.width_px},
               {"height_px", plan.height_px},
               {"frames", frames},
               {"partitions", partitions}});
  WriteJsonFile(path, Plan::kKind, Plan::kVersion, body);
}

Plan MakePlan(const std::string& workspace, const DatasetOptions& dataset,
              const PartitionLayoutOptions& layout_options) {
  CheckOptions(dataset, "dataset");
  const fs::path root(workspace);
  const std::string cues_path = (root / "relight" / "cues" / "cues.json").string();
  RELIT_REQUIRE(fs::exists(cues_path), cues_path, " is missing: run `relit-relight cues` first");
  const CuesFile cues = ReadCuesFile(cues_path);
  const CamerasFile cameras = ReadCamerasFile((root / "calib" / "cameras.json").string());
  const ProxyFile proxy = ReadProxyFile((root / "reconstruct" / "proxy.json").string());

  Plan plan;
  plan.layout_options = layout_options;
  plan.object_centre_m = proxy.object_centre_m;
  plan.object_radius_m = proxy.object_radius_m;
  plan.width_px = cameras.undistorted_view.width;
  plan.height_px = cameras.undistorted_view.height;
  int unreliable = 0, without_matte = 0, without_image = 0;
  for (const CueFrameRecord& c : cues.frames) {
    const CalibratedFrame* frame = cameras.Find(c.name);
    const ViewMatte* matte = proxy.Find(c.name);
    if (frame == nullptr || frame->image_linear.empty()) {
      ++without_image;
      continue;
    }
    if (matte == nullptr) {
      ++without_matte;
      continue;
    }
    if (!c.light_reliable && dataset.drop_unreliable_lights) {
      ++unreliable;
      continue;
    }
    PlanFrame f;
    f.name = c.name;
    f.cues = c.file;
    f.image = frame->image_linear;
    f.matte = matte->matte;
    const Eigen::Vector3d centre = c.cam_from_world.Inverse().translation;
    RELIT_REQUIRE((centre - proxy.object_centre_m).norm() > 1e-6, "frame ", c.name,
                  ": the camera sits at the object centre");
    f.direction = (centre - proxy.object_centre_m).normalized();
    f.light_position_m = c.light_position_m;
    plan.frames.push_back(f);
  }
  if (without_image + without_matte + unreliable > 0) {
    spdlog::warn("plan: dropped {} frames without an undistorted image, {} without a matte, {} with an unreliable "
                 "flash position (dataset.drop_unreliable_lights)", without_image, without_matte, unreliable);
  }
  RELIT_REQUIRE(plan.frames.size() >= 2, "plan: only ", plan.frames.size(),
                " usable phone V frames (need images from calib, mattes from reconstruct and flash positions)");
  if (dataset.holdout_every > 0) {
    // Centre the held-out frames in each block so the first and last frames still train.
    for (size_t i = 0; i < plan.frames.size(); ++i) {
      plan.frames[i].validation = static_cast<int>(i % dataset.holdout_every) == dataset.holdout_every / 2;
    }
  }

  const PartitionLayout layout = plan.Layout();
  for (int p = 0; p < layout.partition_count(); ++p) {
    PlanPartition partition;
    partition.index = p;
    partition.direction = layout.vertices()[p];
    plan.partitions.push_back(partition);
  }
  for (size_t i = 0; i < plan.frames.size(); ++i) {
    for (int p : layout.PartitionsOf(plan.frames[i].direction)) {
      auto& list = plan.frames[i].validation ? plan.partitions[p].validation_frames : plan.partitions[p].train_frames;
      list.push_back(static_cast<int>(i));
    }
  }

  // M: a high quantile of the training targets' brightest channel on the object.
  std::vector<float> peaks;
  Progress progress("plan: scan targets", static_cast<int64_t>(plan.frames.size()));
  for (const PlanFrame& f : plan.frames) {
    progress.Advance();
    if (f.validation) continue;
    const Image image = ReadImage((root / f.image).string());
    const Image matte = ReadImage((root / f.matte).string());
    RELIT_REQUIRE(image.width() == matte.width() && image.height() == matte.height(), "frame ", f.name,
                  ": image ", f.image, " and matte ", f.matte, " differ in size");
    for (int y = 0; y < image.height(); ++y) {
      for (int x = 0; x < image.width(); ++x) {
        if (matte.at(x, y, 0) < 0.5f) continue;
        const float* p = image.pixel(x, y);
        peaks.push_back(std::max({p[0], p[1], p[2]}));
      }
    }
  }
  progress.Finish();
  RELIT_REQUIRE(!peaks.empty(), "plan: the mattes of all training frames are empty: the object is never seen "
                "(check the reconstruct stage's mattes)");
  const size_t k = std::min(peaks.size() - 1, static_cast<size_t>(dataset.max_radiance_quantile * peaks.size()));
  std::nth_element(peaks.begin(), peaks.begin() + k, peaks.end());
  plan.max_radiance = std::max(1e-6, static_cast<double>(peaks[k]) * dataset.max_radiance_margin);
  return plan;
}

void RunPlanStage(const std::string& workspace, const DatasetOptions& dataset,
                  const PartitionLayoutOptions& layout, RunRecord& record) {
  Plan plan;
  {
    auto timer = record.Time("plan");
    plan = MakePlan(workspace, dataset, layout);
  }
  StageRun out(AtomicDir(fs::path(workspace) / "relight" / "plan"), record);
  WritePlan((out.path() / "plan.json").string(), plan);
  int training = 0;
  for (const PlanFrame& f : plan.frames) training += f.validation ? 0 : 1;
  record.Set("frames", static_cast<int>(plan.frames.size()));
  record.Set("training_frames", training);
  record.Set("max_radiance", plan.max_radiance);
  out.Commit();
  for (const PlanPartition& p : plan.partitions) {
    spdlog::info("plan: partition {:2d}: {} training, {} validation frames", p.index, p.train_frames.size(),
                 p.validation_frames.size());
  }
  spdlog::info("plan: {} frames ({} training), M = {:.4g}", plan.frames.size(), training, plan.max_radiance);
}

}  // namespace relit::relight
