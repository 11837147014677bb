// The Deferred Neural Lighting model of one view partition and its training.
//
//   texture  = NeuralTexture(uv, uv derivatives, coverage)          [B, 5C, H, W]
//   rgb_log  = Renderer(LogEncode(texture x tiled cues))             [B, 3, H, W]
//   mask     = MaskNet(texture)  (a logit)                           [B, 1, H, W]
//   RGBA     = (Decode(rgb_log) * sigmoid(mask), sigmoid(mask))      premultiplied
// That is variant "dnl". Variant "residual" (the default) corrects a
// per-texel linear regression of the cues and the proxy's coverage instead:
//   rgb_log  = LogEncode(sum_k w_k(texel) cue_k) + g_r Renderer(...)
//   mask     = logit(coverage) + g_m MaskNet(texture)   (model.mask_correction;
//              else logit(coverage): no mask network, no mask loss)
// with w the least-squares fit of the training frames (warm_start.h) and the
// gates g_r, g_m learnt from 0, so training starts from the cues-only
// baseline's image and the proxy's alpha.
//
// Loss (per batch):
//   rgb  = sum(matte * |rgb_log - LogEncode(target_rgb)|) / (3 sum(matte))
//          (L1 in log space, only where the object is: the matte weights it)
//   mask = mean BCE-with-logits(mask logit, matte)
//   total = rgb + mask_loss_weight * mask        (weight 1 by default)
//
// Tensors are float32 on the model's device; Batch tensors may be on any
// device and are moved by Forward/Step.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include "relight/cue_frames.h"
#include "relight/log_encoding.h"
#include "relight/networks.h"
#include "relight/neural_texture.h"
#include "relight/learn_options.h"

namespace relit {
class OptionsReader;
}

namespace relit::relight {



// One batch of frames; every per-pixel tensor has the same B, H, W.
struct Batch {
  torch::Tensor uv;              // [B, H, W, 2]  OBJ convention (v up)
  torch::Tensor uv_derivatives;  // [B, H, W, 4]  dudx, dvdx, dudy, dvdy
  torch::Tensor coverage;        // [B, 1, H, W]  proxy coverage in [0, 1]
  torch::Tensor cues;            // [B, L, H, W] light input: radiance cues (3 x bases, default 15) or sh (21)
  torch::Tensor target_rgb;      // [B, 3, H, W]  linear radiance (training only)
  torch::Tensor target_matte;    // [B, 1, H, W]  in [0, 1] (training only)

  int64_t batch_size() const { return uv.size(0); }
  int64_t height() const { return uv.size(1); }
  int64_t width() const { return uv.size(2); }
  bool has_targets() const { return target_rgb.defined() && target_matte.defined(); }
  // Throws relit::Error naming the tensor whose shape is wrong.
  void Check(bool need_targets) const;
  Batch To(const torch::Device& device) const;
};

// The same window [top, top + height) x [left, left + width) of every
// per-pixel tensor.
Batch CropBatch(const Batch& batch, int64_t top, int64_t left, int64_t height, int64_t width);

// A random crop_px x crop_px window (positions drawn from `generator`),
// preferring windows where the matte (or, without targets, the coverage) is
// non-zero: up to 8 draws, the first one that sees the object wins. Returns
// the batch unchanged when crop_px is 0 or not smaller than the frame.
Batch RandomCrop(const Batch& batch, int crop_px, at::Generator& generator);

// The window of `batch` around the proxy's coverage (any frame of the
// batch), widened by margin_px on each side and aligned to multiples of 4
// inside the frame; the whole batch when nothing is covered. `top`/`left`
// receive the window's offset.
Batch ObjectWindow(const Batch& batch, int margin_px, int64_t* top = nullptr, int64_t* left = nullptr);

// `rgba` [B, 4, H, W] premultiplied (DnlModelImpl::Render's) with its colour
// blurred by a Gaussian `sigma_texels` wide in texels of a `resolution`-texel
// texture, within the object: rgb' = G*(rgb) alpha / G*(alpha), alpha as it
// was. A frame's width in pixels is sigma_texels over the median texel
// footprint (OpenGL's rho, from batch.uv_derivatives) of its covered
// pixels; frames without covered pixels are returned as they are.
torch::Tensor BlurWithinCoverage(const torch::Tensor& rgba, const Batch& batch, double sigma_texels,
                                 int64_t resolution);

// The output blur widths the train stage tries on the held-out frames
// (ModelOptions::output_blur_texels -1), in texels.
const std::vector<double>& OutputBlurCandidates();

struct ModelOutput {
  torch::Tensor rgb_log;     // [B, 3, H, W] log-encoded RGB, in [-1, 1]
  torch::Tensor mask_logit;  // [B, 1, H, W]
};

struct Losses {
  torch::Tensor total, rgb, mask;  // scalars
};

class DnlModelImpl : public torch::nn::Module {
 public:
  // Builds on options.device. Requires options.max_radiance > 0.
  explicit DnlModelImpl(const ModelOptions& options);

  ModelOutput Forward(const Batch& batch);
  // `saturation_level` > 0: target channels at or above it were clipped by
  // the video and only bound the radiance from below (no loss where the
  // output is brighter), as in the cue fit (CueFitOptions). The bound is
  // the reading x `clip_overshoot` (>= 1), the lift the warm-start fit used
  // (CueFitStats::clip_overshoot), so the training keeps what the fit lifted.
  // `clip_noise` > 0 (the fit's censored model, CueFitStats::clip_noise):
  // instead, a clipped channel's term is the censored-Laplace counterpart
  // of the L1: b x -log P(radiance >= reading), b the Laplace scale of that
  // relative noise at the reading in log units. It costs as the L1 below
  // the reading and still pushes up, ever less, above it, as the fit's EM did.
  Losses Loss(const ModelOutput& output, const Batch& batch, double mask_loss_weight = 1.0,
              double saturation_level = 0, double clip_overshoot = 1, double clip_noise = 0) const;
  // Premultiplied linear RGBA [B, 4, H, W]: alpha = sigmoid(mask logit);
  // RGB = decoded RGB x alpha (dnl), or the decoded RGB itself where the
  // proxy covers the pixel (residual: its cues carry the coverage). No gradients. With object_window_margin_px > 0 the
  // networks see only the object's window, as in training; outside it the
  // image is empty.
  torch::Tensor Render(const Batch& batch);
  // Render's output blur in texels (ModelOptions::output_blur_texels): the
  // fixed option, or the width chosen after training (checkpoint.json); 0 =
  // none. Render without it: set 0.
  double output_blur_texels() const { return output_blur_texels_; }
  void set_output_blur_texels(double sigma_texels);

  const ModelOptions& options() const { return options_; }
  const torch::Device& device() const { return device_; }
  const LogEncoding& encoding() const { return encoding_; }
  NeuralTexture& texture() { return texture_; }
  ResnetGenerator& renderer() { return renderer_; }
  ResnetGenerator& mask_net() { return mask_net_; }
  // The dnl variant always; the residual one with model.mask_correction.
  bool has_mask_net() const { return !options_.residual() || options_.mask_correction; }
  // Residual variant only (undefined for dnl): the cue regression's per-texel
  // weights [1, 15, R, R] and the two correction gates.
  torch::Tensor& regression() { return regression_; }
  std::vector<torch::Tensor> gates() const;

 private:
  ModelOptions options_;
  torch::Device device_;
  LogEncoding encoding_;
  NeuralTexture texture_{nullptr};
  ResnetGenerator renderer_{nullptr};
  ResnetGenerator mask_net_{nullptr};
  torch::Tensor regression_, renderer_gate_, mask_gate_;
  double output_blur_texels_ = 0;
};
TORCH_MODULE(DnlModel);

// Model + Adam + crop generator + step counter. Construction seeds torch's
// global generator with options.seed, so models built with the same options
// start identical.
class Trainer {
 public:
  Trainer(const ModelOptions& model_options, const TrainOptions& train_options);

  // One optimisation step on a (random crop of the) batch; returns the
  // losses (detached).
  Losses Step(const Batch& batch);

  DnlModel& model() { return model_; }
  torch::optim::Adam& optimizer() { return *optimizer_; }
  at::Generator& generator() { return generator_; }
  const TrainOptions& train_options() const { return train_options_; }
  int64_t step() const { return step_; }
  void set_step(int64_t step) { step_ = step; }
  // > 0: targets at or above this level were clipped by the video (a
  // one-sided loss there, DnlModelImpl::Loss). The train stage sets it from
  // train.cue_fit.saturation_level; 0 (augmentation's rendered targets).
  void set_saturation_level(double level) { saturation_level_ = level; }
  // >= 1: clipped targets bound the output from below at reading x factor.
  void set_clip_overshoot(double factor);
  double clip_overshoot() const { return clip_overshoot_; }
  // > 0: clipped targets enter the loss as censored at their readings
  // with this relative noise (DnlModelImpl::Loss); 0 = bounds.
  void set_clip_noise(double relative_noise);
  double clip_noise() const { return clip_noise_; }

 private:
  TrainOptions train_options_;
  DnlModel model_{nullptr};
  std::unique_ptr<torch::optim::Adam> optimizer_;
  at::Generator generator_;
  int64_t step_ = 0;
  double saturation_level_ = 0;
  double clip_overshoot_ = 1;
  double clip_noise_ = 0;
};

// "cpu", "cuda" (Error when CUDA is not available) or "auto".
torch::Device ResolveDevice(const std::string& name);

// Intra-op threads and deterministic algorithms (strict on CPU; warn-only on
// CUDA, where some kernels, e.g. grid_sample's backward, have no
// deterministic version). Process-wide.
void ConfigureTorch(int threads, const torch::Device& device);

}  // namespace relit::relight
