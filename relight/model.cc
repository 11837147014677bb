#include "relight/model.h"

#include <ATen/CPUGeneratorImpl.h>
#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/options.h"

namespace relit::relight {
namespace {

namespace F = torch::nn::functional;

void CheckShape(const torch::Tensor& t, const char* name, std::vector<int64_t> expected) {
  bool ok = t.defined() && t.dim() == static_cast<int64_t>(expected.size());
  for (size_t i = 0; ok && i < expected.size(); ++i) ok = t.size(static_cast<int64_t>(i)) == expected[i];
  RELIT_REQUIRE(ok, "batch: ", name, " must have shape ", c10::IntArrayRef(expected), ", got ",
                t.defined() ? t.sizes() : c10::IntArrayRef{});
}

double RequireMaxRadiance(double max_radiance) {
  RELIT_REQUIRE(max_radiance > 0, "model: max_radiance must be set (> 0) before building the model; it is "
                                  "the scene's maximum radiance M of the log encoding");
  return max_radiance;
}

// The proxy coverage as a logit, kept inside [floor, 1 - floor] so uncovered
// pixels stay finite: the residual variant's alpha before its correction.
torch::Tensor CoverageLogit(const torch::Tensor& coverage, double floor = 1e-3) {
  const auto clamped = coverage.clamp(floor, 1.0 - floor);
  return torch::log(clamped) - torch::log1p(-clamped);
}

// The residual variant's alpha logit: the coverage's plus the mask
// network's correction, only within band_px of the proxy's coverage. Farther
// out alpha is 0 (a logit of -30): otherwise the coverage logit's 1e-3 floor
// and the network's small outputs over the background add ~0.002 of alpha
// to every background pixel (measured: alpha MAE 0.0060 vs the coverage's
// 0.0041 on the demo's eval views). band_px 0: no band (checkpoints from
// before it).
torch::Tensor MaskLogit(const torch::Tensor& coverage, const torch::Tensor& correction, int band_px) {
  const auto logit = CoverageLogit(coverage) + correction;
  if (band_px <= 0) return logit;
  const auto covered = (coverage > 0).to(coverage.dtype());
  const auto band = F::max_pool2d(covered, F::MaxPool2dFuncOptions(2 * band_px + 1).stride(1).padding(band_px));
  return torch::where(band > 0, logit, torch::full_like(logit, -30.0));
}

// Without a mask network the alpha is the coverage itself: no 1e-3 floor
// (there is no correction to keep finite); +-30 (alpha within 1e-13 of 0 or 1)
// where the proxy covers the pixel fully or not at all.
torch::Tensor CoverageOnlyLogit(const torch::Tensor& coverage) {
  const auto logit = CoverageLogit(coverage, 1e-6);
  return torch::where(coverage <= 0, torch::full_like(logit, -30.0),
                      torch::where(coverage >= 1, torch::full_like(logit, 30.0), logit));
}

// A normalised 1-D Gaussian of `sigma` samples, radius ceil(3 sigma) (1 to 24).
torch::Tensor GaussianKernel(double sigma, const torch::TensorOptions& options) {
  const int radius = std::clamp(static_cast<int>(std::ceil(3 * sigma)), 1, 24);
  cv::Mat kernel = cv::getGaussianKernel(2 * radius + 1, sigma, CV_32F);
  return torch::from_blob(kernel.ptr<float>(), {kernel.rows}, torch::kFloat).clone().to(options);  // own the data
}

// Separable Gaussian of every channel of x [1, C, H, W], zero outside.
torch::Tensor GaussianBlur(const torch::Tensor& x, double sigma) {
  const torch::Tensor k = GaussianKernel(sigma, x.options());
  const int64_t c = x.size(1), n = k.size(0), radius = n / 2;
  const auto across = F::conv2d(x, k.view({1, 1, 1, n}).expand({c, 1, 1, n}).contiguous(),
                                F::Conv2dFuncOptions().padding({0, radius}).groups(c));
  return F::conv2d(across, k.view({1, 1, n, 1}).expand({c, 1, n, 1}).contiguous(),
                   F::Conv2dFuncOptions().padding({radius, 0}).groups(c));
}

}  // namespace

const std::vector<double>& OutputBlurCandidates() {
  static const std::vector<double> candidates = {0, 0.25, 0.5, 0.75, 1, 1.25, 1.5, 2, 3};
  return candidates;
}

torch::Tensor BlurWithinCoverage(const torch::Tensor& rgba, const Batch& batch, double sigma_texels,
                                 int64_t resolution) {
  if (sigma_texels <= 0) return rgba;
  torch::NoGradGuard no_grad;
  const auto d = batch.uv_derivatives.to(rgba.options()) * static_cast<double>(resolution);  // [B, H, W, 4]
  const auto along_x = torch::sqrt(d.select(3, 0).square() + d.select(3, 1).square());
  const auto along_y = torch::sqrt(d.select(3, 2).square() + d.select(3, 3).square());
  const auto footprint = torch::maximum(along_x, along_y);  // texels per pixel, [B, H, W]
  const auto covered = batch.coverage.to(rgba.options()).select(1, 0) > 0.5;
  std::vector<torch::Tensor> frames;
  for (int64_t b = 0; b < rgba.size(0); ++b) {
    const torch::Tensor frame = rgba.slice(0, b, b + 1);
    const torch::Tensor rho = footprint[b].masked_select(covered[b]);
    const double texels_per_px = rho.numel() > 0 ? rho.median().item<double>() : 0.0;
    if (!(texels_per_px > 0) || !std::isfinite(texels_per_px)) {
      frames.push_back(frame);
      continue;
    }
    const double sigma_px = sigma_texels / texels_per_px;
    const torch::Tensor rgb = frame.slice(1, 0, 3), alpha = frame.slice(1, 3, 4);
    const torch::Tensor weight = GaussianBlur(alpha, sigma_px);
    const torch::Tensor blurred = GaussianBlur(rgb, sigma_px) * alpha / weight.clamp_min(1e-6);
    frames.push_back(torch::cat({torch::where(alpha > 0, blurred, rgb), alpha}, 1));
  }
  return torch::cat(frames, 0);
}










void Batch::Check(bool need_targets) const {
  RELIT_REQUIRE(uv.defined() && uv.dim() == 4, "batch: uv must be [B, H, W, 2]");
  const int64_t b = uv.size(0), h = uv.size(1), w = uv.size(2);
  CheckShape(uv, "uv", {b, h, w, 2});
  CheckShape(uv_derivatives, "uv_derivatives", {b, h, w, 4});
  CheckShape(coverage, "coverage", {b, 1, h, w});
  RELIT_REQUIRE(cues.defined() && cues.dim() == 4, "batch: cues must be [B, L, H, W]");
  CheckShape(cues, "cues", {b, cues.size(1), h, w});
  if (need_targets || target_rgb.defined()) CheckShape(target_rgb, "target_rgb", {b, 3, h, w});
  if (need_targets || target_matte.defined()) CheckShape(target_matte, "target_matte", {b, 1, h, w});
}

Batch Batch::To(const torch::Device& device) const {
  auto move = [&](const torch::Tensor& t) { return t.defined() ? t.to(device, torch::kFloat) : t; };
  return {move(uv), move(uv_derivatives), move(coverage), move(cues), move(target_rgb), move(target_matte)};
}

Batch CropBatch(const Batch& batch, int64_t top, int64_t left, int64_t height, int64_t width) {
  RELIT_REQUIRE(top >= 0 && left >= 0 && height >= 1 && width >= 1 && top + height <= batch.height() &&
                    left + width <= batch.width(),
                "crop [", top, ", ", top + height, ") x [", left, ", ", left + width, ") outside the ",
                batch.height(), " x ", batch.width(), " frame");
  auto hwc = [&](const torch::Tensor& t) {  // [B, H, W, C]
    return t.defined() ? t.slice(1, top, top + height).slice(2, left, left + width) : t;
  };
  auto chw = [&](const torch::Tensor& t) {  // [B, C, H, W]
    return t.defined() ? t.slice(2, top, top + height).slice(3, left, left + width) : t;
  };
  return {hwc(batch.uv), hwc(batch.uv_derivatives), chw(batch.coverage), chw(batch.cues),
          chw(batch.target_rgb), chw(batch.target_matte)};
}

Batch RandomCrop(const Batch& batch, int crop_px, at::Generator& generator) {
  const int64_t h = batch.height(), w = batch.width();
  if (crop_px <= 0 || (crop_px >= h && crop_px >= w)) return batch;
  const int64_t ch = std::min<int64_t>(crop_px, h), cw = std::min<int64_t>(crop_px, w);
  const torch::Tensor& object = batch.target_matte.defined() ? batch.target_matte : batch.coverage;
  Batch crop;
  for (int attempt = 0; attempt < 8; ++attempt) {
    // Always two draws per attempt, so the generator advances predictably.
    const int64_t top = torch::randint(0, h - ch + 1, {1}, generator).item<int64_t>();
    const int64_t left = torch::randint(0, w - cw + 1, {1}, generator).item<int64_t>();
    crop = CropBatch(batch, top, left, ch, cw);
    if (!object.defined()) break;
    const auto window = object.slice(2, top, top + ch).slice(3, left, left + cw);
    if (window.max().item<double>() > 0) break;
  }
  return crop;
}

Batch ObjectWindow(const Batch& batch, int margin_px, int64_t* top_out, int64_t* left_out) {
  const int64_t h = batch.height(), w = batch.width();
  const auto covered = (batch.coverage > 0).any(0).any(0);  // [H, W]
  const auto rows = torch::nonzero(covered.any(1)), cols = torch::nonzero(covered.any(0));
  int64_t top = 0, left = 0, bottom = h, right = w;
  if (rows.numel() > 0) {
    auto align = [](int64_t lo, int64_t hi, int64_t size, int64_t* start, int64_t* end) {
      *start = std::max<int64_t>(0, lo / 4 * 4);
      *end = std::min<int64_t>(size, (hi + 3) / 4 * 4);
      while (*end - *start < 8 && (*start > 0 || *end < size)) {  // the generator needs >= 8
        if (*start > 0) *start -= 4;
        if (*end - *start < 8 && *end < size) *end = std::min<int64_t>(size, *end + 4);
      }
    };
    align(rows.min().item<int64_t>() - margin_px, rows.max().item<int64_t>() + 1 + margin_px, h, &top, &bottom);
    align(cols.min().item<int64_t>() - margin_px, cols.max().item<int64_t>() + 1 + margin_px, w, &left, &right);
  }
  if (top_out) *top_out = top;
  if (left_out) *left_out = left;
  return CropBatch(batch, top, left, bottom - top, right - left);
}

DnlModelImpl::DnlModelImpl(const ModelOptions& options)
    : options_(options),
      device_(ResolveDevice(options.device)),
      encoding_(RequireMaxRadiance(options.max_radiance)) {
  CheckOptions(options_, "model");
  texture_ = register_module("texture", NeuralTexture(options_.TextureOptions()));
  renderer_ = register_module("renderer", ResnetGenerator(options_.RendererOptions()));
  if (has_mask_net()) mask_net_ = register_module("mask", ResnetGenerator(options_.MaskOptions()));
  if (options_.residual()) {
    // Weights of the cue regression, [k * 3 + c] per texel, set by the warm
    // start (warm_start.h); gates at 0 so the corrections start as none
    // without zeroing any network layer (ReZero): Adam's first, sign-like
    // steps on a zeroed last layer move every output pixel the same way.
    const int64_t r = options_.texture_resolution_px;
    regression_ = register_parameter("regression", torch::zeros({1, 3 * kBasisCount, r, r}));
    renderer_gate_ = register_parameter("renderer_gate", torch::zeros({1}));
    mask_gate_ = register_parameter("mask_gate", torch::zeros({1}));
    output_blur_texels_ = std::max(0.0, options_.output_blur_texels);  // auto: none until chosen
  }
  to(device_);
}

ModelOutput DnlModelImpl::Forward(const Batch& batch_in) {
  batch_in.Check(/*need_targets=*/false);
  const Batch batch = batch_in.To(device_);
  RELIT_REQUIRE(batch.cues.size(1) == options_.format.light_channels(), "model: the batch has ",
                batch.cues.size(1), " light channels, the model reads ", options_.format.Describe(), " (",
                options_.format.light_channels(), " channels): cue frames and model come from different "
                "cues.input / cues.bases settings");
  const auto texture = texture_->forward(batch.uv, batch.uv_derivatives, batch.coverage);
  const auto input = options_.format.is_sh() ? BuildShNetworkInput(texture, batch.cues, encoding_.max_radiance())
                                             : BuildNetworkInput(texture, batch.cues, encoding_.max_radiance());
  if (!options_.residual()) return {renderer_->forward(input), mask_net_->forward(texture)};
  // Corrections on top of the cue regression and of the proxy's coverage.
  // The cues already carry the coverage (a silhouette pixel's paths that
  // miss the proxy add nothing), so the weights are read unscaled, as the
  // cue fit predicts (CueTextureFit::Predict).
  const auto covered = (batch.coverage > 0).to(batch.coverage.dtype());
  const auto weights = options_.cue_fit == "smooth" ? SampleBilinear(regression_, batch.uv, covered)
                                                   : SampleNearest(regression_, batch.uv, covered);
  const auto regression = encoding_.Encode(CueRegression(weights, batch.cues));
  const auto rgb_log = regression + renderer_gate_ * renderer_->forward(input);
  if (!has_mask_net()) return {rgb_log, CoverageOnlyLogit(batch.coverage)};
  return {rgb_log, MaskLogit(batch.coverage, mask_gate_ * mask_net_->forward(texture), options_.mask_band_px)};
}

std::vector<torch::Tensor> DnlModelImpl::gates() const {
  if (!options_.residual()) return {};
  return {renderer_gate_, mask_gate_};
}

Losses DnlModelImpl::Loss(const ModelOutput& output, const Batch& batch_in, double mask_loss_weight,
                          double saturation_level, double clip_overshoot, double clip_noise) const {
  batch_in.Check(/*need_targets=*/true);
  const Batch batch = batch_in.To(device_);
  const auto& matte = batch.target_matte;
  const auto target_log = encoding_.Encode(batch.target_rgb);
  // L1 in log space where the object is: the matte weights each pixel, the
  // mean is over the matte's area (at least one pixel).
  auto error = (output.rgb_log - target_log).abs();
  if (saturation_level > 0) {
    RELIT_REQUIRE(clip_overshoot >= 1, "clip_overshoot must be >= 1, got ", clip_overshoot);
    RELIT_REQUIRE(clip_noise >= 0, "clip_noise must be >= 0, got ", clip_noise);
    torch::Tensor clipped_error;
    if (clip_noise > 0) {
      // The L1 is a Laplace likelihood's -log times its scale; b = the mean
      // absolute deviation of a normal noise of that relative size at the
      // reading (floored: where() passes no NaN from the branch not taken).
      const auto b = (std::sqrt(2.0 / M_PI) * (encoding_.Encode(batch.target_rgb * (1.0 + clip_noise)) - target_log))
                         .clamp_min(1e-6);
      const auto d = output.rgb_log - target_log;
      const auto above = -b * torch::log1p(-0.5 * torch::exp(-d.clamp_min(0.0) / b));
      const auto below = (-d).clamp_min(0.0) + b * std::log(2.0);
      clipped_error = torch::where(d < 0, below, above);
    } else {
      const auto to_bound = clip_overshoot > 1 ? output.rgb_log - encoding_.Encode(batch.target_rgb * clip_overshoot)
                                               : output.rgb_log - target_log;
      clipped_error = to_bound.clamp_max(0.0).abs();
    }
    error = torch::where(batch.target_rgb >= saturation_level, clipped_error, error);
  }
  const auto rgb = (matte * error).sum() / (matte.sum() * 3.0).clamp_min(1.0);
  // Without a mask network the alpha is the coverage: nothing to learn.
  const auto mask = has_mask_net() ? F::binary_cross_entropy_with_logits(output.mask_logit, matte)
                                   : torch::zeros({}, rgb.options());
  return {rgb + mask_loss_weight * mask, rgb, mask};
}

torch::Tensor DnlModelImpl::Render(const Batch& batch) {
  torch::NoGradGuard no_grad;
  ModelOutput output;
  if (options_.object_window_margin_px > 0) {
    int64_t top = 0, left = 0;
    const Batch window = ObjectWindow(batch, options_.object_window_margin_px, &top, &left);
    const ModelOutput inside = Forward(window);
    const auto options = inside.rgb_log.options();
    // Outside the window: no radiance, and no coverage (what the residual
    // variant reads there); the networks' outputs inside.
    output.rgb_log = torch::full({batch.batch_size(), 3, batch.height(), batch.width()}, -1.0, options);
    const auto coverage = batch.coverage.to(options);
    output.mask_logit = !options_.residual() ? CoverageLogit(coverage)
                        : has_mask_net()     ? MaskLogit(coverage, torch::zeros_like(coverage), options_.mask_band_px)
                                             : CoverageOnlyLogit(coverage);
    output.rgb_log.slice(2, top, top + window.height()).slice(3, left, left + window.width()).copy_(inside.rgb_log);
    output.mask_logit.slice(2, top, top + window.height()).slice(3, left, left + window.width())
        .copy_(inside.mask_logit);
  } else {
    output = Forward(batch);
  }
  const auto alpha = torch::sigmoid(output.mask_logit);
  // The residual variant's radiance is premultiplied already: its cue
  // regression carries the coverage (Forward) and it trains on frames whose
  // silhouette pixels are partly background. Times alpha again would darken
  // every silhouette pixel by its coverage.
  const auto premultiply =
      options_.residual() ? (batch.coverage.to(alpha.options()) > 0).to(alpha.dtype()) : alpha;
  const torch::Tensor rgba = torch::cat({encoding_.Decode(output.rgb_log) * premultiply, alpha}, 1);
  return options_.residual() ? BlurWithinCoverage(rgba, batch, output_blur_texels_, options_.texture_resolution_px)
                             : rgba;
}

void DnlModelImpl::set_output_blur_texels(double sigma_texels) {
  RELIT_REQUIRE(std::isfinite(sigma_texels) && sigma_texels >= 0, "output blur must be >= 0 texels, got ",
                sigma_texels);
  output_blur_texels_ = sigma_texels;
}

Trainer::Trainer(const ModelOptions& model_options, const TrainOptions& train_options)
    : train_options_(train_options),
      generator_(at::make_generator<at::CPUGeneratorImpl>(train_options.seed)) {
  CheckOptions(train_options_, "train");
  CheckOptions(model_options, "model");
  ConfigureTorch(train_options_.threads, ResolveDevice(model_options.device));
  torch::manual_seed(train_options_.seed);
  model_ = DnlModel(model_options);
  // Two parameter groups: the neural texture may learn faster than the
  // networks (each texel sees few pixels per step).
  std::vector<torch::Tensor> networks;
  for (const auto& p : model_->renderer()->parameters()) networks.push_back(p);
  if (model_->has_mask_net()) {
    for (const auto& p : model_->mask_net()->parameters()) networks.push_back(p);
  }
  for (const auto& p : model_->gates()) networks.push_back(p);
  const double texture_lr =
      train_options_.texture_learning_rate > 0 ? train_options_.texture_learning_rate : train_options_.learning_rate;
  const auto betas = std::make_tuple(train_options_.beta1, train_options_.beta2);
  std::vector<torch::optim::OptimizerParamGroup> groups;
  groups.emplace_back(std::vector<torch::Tensor>{model_->texture()->texels()},
                      std::make_unique<torch::optim::AdamOptions>(torch::optim::AdamOptions(texture_lr).betas(betas)));
  groups.emplace_back(networks, std::make_unique<torch::optim::AdamOptions>(
                                    torch::optim::AdamOptions(train_options_.learning_rate).betas(betas)));
  if (model_->options().residual()) {
    // The least-squares weights are already the regression's optimum for
    // squared error; a rate of 0 keeps them (no gradient at all).
    if (train_options_.regression_learning_rate > 0) {
      groups.emplace_back(std::vector<torch::Tensor>{model_->regression()},
                          std::make_unique<torch::optim::AdamOptions>(
                              torch::optim::AdamOptions(train_options_.regression_learning_rate).betas(betas)));
    } else {
      model_->regression().requires_grad_(false);
    }
  }
  optimizer_ = std::make_unique<torch::optim::Adam>(
      std::move(groups), torch::optim::AdamOptions(train_options_.learning_rate).betas(betas));
}

Losses Trainer::Step(const Batch& batch) {
  batch.Check(/*need_targets=*/true);
  model_->train();
  const int margin_px = model_->options().object_window_margin_px;
  const Batch crop = margin_px > 0 ? ObjectWindow(batch, margin_px) : RandomCrop(batch, train_options_.crop_px, generator_);
  optimizer_->zero_grad();
  const ModelOutput output = model_->Forward(crop);
  const Losses losses =
      model_->Loss(output, crop, train_options_.mask_loss_weight, saturation_level_, clip_overshoot_, clip_noise_);
  losses.total.backward();
  optimizer_->step();
  ++step_;
  return {losses.total.detach(), losses.rgb.detach(), losses.mask.detach()};
}

void Trainer::set_clip_overshoot(double factor) {
  RELIT_REQUIRE(factor >= 1, "clip_overshoot must be >= 1, got ", factor);
  clip_overshoot_ = factor;
}

void Trainer::set_clip_noise(double relative_noise) {
  RELIT_REQUIRE(relative_noise >= 0, "clip_noise must be >= 0, got ", relative_noise);
  clip_noise_ = relative_noise;
}

torch::Device ResolveDevice(const std::string& name) {
  if (name == "cpu") return torch::kCPU;
  const bool cuda = torch::cuda::is_available();
  if (name == "auto") return cuda ? torch::Device(torch::kCUDA) : torch::Device(torch::kCPU);
  RELIT_REQUIRE(name == "cuda", "device must be cpu, cuda or auto, got '", name, "'");
  RELIT_REQUIRE(cuda, "device cuda requested, but this LibTorch build has no CUDA support or no GPU is "
                      "visible; use device: cpu (or auto)");
  return torch::kCUDA;
}

void ConfigureTorch(int threads, const torch::Device& device) {
  RELIT_REQUIRE(threads >= 1, "torch threads must be >= 1, got ", threads);
  torch::set_num_threads(threads);
  at::globalContext().setDeterministicAlgorithms(true, /*warn_only=*/device.is_cuda());
  at::globalContext().setDeterministicCuDNN(true);
  at::globalContext().setBenchmarkCuDNN(false);
}

}  // namespace relit::relight
