// Training and rendering tensors from workspace files: a cue frame (see
// cue_frames.h) becomes a Batch of one frame; with its target image and
// matte it becomes a training example.
#pragma once

#include <string>

#include <torch/torch.h>

#include "core/image.h"
#include "relight/model.h"
#include "relight/plan.h"

namespace relit::relight {

// A Batch (B = 1, float32, CPU) from a cue frame of `format`, without targets.
Batch CueFrameToBatch(const Image& cue_frame, const CueFormat& format = {});

// Sets the batch's targets: channels 0-2 of `rgb` (linear radiance) and
// channel `matte_channel` of `matte` (clamped to [0, 1]). Sizes must match
// the batch (the caller checks and names the files).
void AttachTargets(Batch& batch, const Image& rgb, const Image& matte, int matte_channel = 0);

// Thresholds the frames' target mattes at `threshold` (> 0; 0 = unchanged).
void ThresholdMattes(std::vector<Batch>& frames, double threshold);

// A Batch with targets from plan frame `frame` of `workspace`. Throws
// relit::Error naming the file when sizes disagree.
Batch LoadPlanFrame(const std::string& workspace, const PlanFrame& frame, const CueFormat& format = {});

// Up to `max_frames` of the partition's validation frames, spread evenly
// over them, with their mattes thresholded at `matte_threshold`
// (ThresholdMattes): what training and augmentation validate on.
std::vector<Batch> LoadValidationFrames(const std::string& workspace, const Plan& plan, const PlanPartition& part,
                                        int max_frames, const CueFormat& format, double matte_threshold);

// The model's premultiplied RGBA for a whole frame of any size: the batch is
// zero-padded to a multiple of 4 (the networks downsample twice) and the
// result cropped back. Returns an Image with channels R, G, B, A.
Image RenderFrame(DnlModel& model, const Batch& batch);
// The same as a [1, 4, H, W] tensor.
torch::Tensor RenderFrameTensor(DnlModel& model, const Batch& batch);

// [1, C, H, W] float tensor -> Image with the given channel names.
Image TensorToImage(const torch::Tensor& chw, std::vector<std::string> names);

}  // namespace relit::relight
