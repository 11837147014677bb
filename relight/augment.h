// `relit-relight augment --partition K`: lighting augmentation (DNL section
// 4.4). A network trained under the flash has only seen one small light;
// augmentation shows it environment lighting, using the linearity of light
// transport:
//
//   1. a set of environment maps: `maps` procedural ones
//      (render::MakeAugmentationMap: skies, studios, smooth lobes) plus the
//      user's EXR/HDR maps in `map_dir`, each scaled so its irradiance
//      (pi x mean radiance) is `exposure` x the flash's at the capture
//      distance, which keeps augmented images in the captures' range;
//   2. for each augmented training view, `maps_per_view` maps are drawn and
//      their light is split into `directions` directional lights: importance
//      sampled from the mixture of the drawn maps (one set of directions
//      serves all of them; weight = L_m(w) / (K p_mix(w))), or with
//      sampling: all, a fixed Fibonacci set whose weights integrate each map
//      over the directions' Voronoi cells (for strongly specular scenes,
//      where importance sampling would miss highlights);
//   3. the point-light model (W/relight/partitions, blended across
//      partitions as when rendering) relights the view under each
//      directional light (as bright on the object as the flash, the range
//      the networks know, then scaled to its weight); the weighted sum is the augmented target under
//      the map, with the mask network's alpha as its matte; its input is the
//      view's radiance cues rendered under the map itself;
//   4. the partition is fine-tuned from its point-light checkpoint,
//      alternating captured and augmented frames, for `steps` steps.
//
// Output W/relight/augment/KK/: frames/ (per view and map: NAME.cues.exr, a
// cue frame, and NAME.target.exr, linear RGB + matte A; resumable per view),
// checkpoint/, log.jsonl, fingerprint.json and train.json (written last: the
// augmented model exists). Rendering and export use it in place of the
// point-light model (asset.h, ModelSet).
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "relight/model.h"
#include "relight/train_stage.h"
#include "relight/learn_options.h"

namespace relit {
class OptionsReader;
class RunRecord;
}

namespace relit::relight {


struct AugmentStageResult {
  bool skipped = false;
  int views = 0;                     // views augmented (including reused ones)
  int frames = 0;                    // augmented frames (views x maps)
  int64_t steps = 0;                 // the trainer's step count at the end
  int64_t resumed_from = 0;
  bool interrupted = false;
  double val_psnr_before_db = 0;     // captured validation frames, point-light model
  double val_psnr_after_db = 0;      // the same frames after fine-tuning
};

AugmentStageResult RunAugmentStage(const std::string& workspace, int partition, const AugmentOptions& options,
                                   const TrainStageOptions& train, bool restart, RunRecord& record);

// True when `augment_dir` (W/relight/augment/KK) was fine-tuned from the
// point-light model now in `point_dir` (W/relight/partitions/KK): its
// fingerprint's source is that model's hash. After the partition is trained
// again (new cues, new options) the augment folder is stale.
bool AugmentedFromCurrentModel(const std::string& augment_dir, const std::string& point_dir);

}  // namespace relit::relight
