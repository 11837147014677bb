#include "relight/networks.h"

#include "core/error.h"
#include "relight/log_encoding.h"
#include "relight/neural_texture.h"

namespace relit::relight {
namespace {

namespace nn = torch::nn;

torch::nn::AnyModule Norm(const std::string& norm, int channels) {
  // CycleGAN's default: no affine parameters, no running statistics.
  if (norm == "instance") {
    return torch::nn::AnyModule(
        nn::InstanceNorm2d(nn::InstanceNorm2dOptions(channels).affine(false).track_running_stats(false)));
  }
  return torch::nn::AnyModule(nn::Identity());
}

nn::Conv2d Conv(int in, int out, int kernel, int stride = 1, int padding = 0) {
  return nn::Conv2d(nn::Conv2dOptions(in, out, kernel).stride(stride).padding(padding).bias(true));
}

}  // namespace



ResnetBlockImpl::ResnetBlockImpl(int channels, const std::string& norm) {
  nn::Sequential body;
  body->push_back(nn::ReflectionPad2d(1));
  body->push_back(Conv(channels, channels, 3));
  body->push_back(Norm(norm, channels));
  body->push_back(nn::ReLU());
  body->push_back(nn::ReflectionPad2d(1));
  body->push_back(Conv(channels, channels, 3));
  body->push_back(Norm(norm, channels));
  body_ = register_module("body", body);
}

torch::Tensor ResnetBlockImpl::forward(const torch::Tensor& x) { return x + body_->forward(x); }

ResnetGeneratorImpl::ResnetGeneratorImpl(const GeneratorOptions& options) : options_(options) {
  options_.Check();
  const int ngf = options_.ngf;
  nn::Sequential model;
  model->push_back(nn::ReflectionPad2d(3));
  model->push_back(Conv(options_.input_channels, ngf, 7));
  model->push_back(Norm(options_.norm, ngf));
  model->push_back(nn::ReLU());
  int channels = ngf;
  for (int i = 0; i < kDownsamplings; ++i) {
    model->push_back(Conv(channels, channels * 2, 3, 2, 1));
    model->push_back(Norm(options_.norm, channels * 2));
    model->push_back(nn::ReLU());
    channels *= 2;
  }
  for (int i = 0; i < options_.n_blocks; ++i) model->push_back(ResnetBlock(channels, options_.norm));
  for (int i = 0; i < kDownsamplings; ++i) {
    if (options_.upsampling == "transposed") {
      model->push_back(nn::ConvTranspose2d(
          nn::ConvTranspose2dOptions(channels, channels / 2, 3).stride(2).padding(1).output_padding(1)));
    } else {
      // Resize-convolution avoids the checkerboard artefacts transposed
      // convolutions can leave.
      model->push_back(nn::Upsample(
          nn::UpsampleOptions().scale_factor(std::vector<double>{2.0, 2.0}).mode(torch::kNearest)));
      model->push_back(nn::ReflectionPad2d(1));
      model->push_back(Conv(channels, channels / 2, 3));
    }
    model->push_back(Norm(options_.norm, channels / 2));
    model->push_back(nn::ReLU());
    channels /= 2;
  }
  model_ = register_module("model", model);
  nn::Sequential head;
  head->push_back(nn::ReflectionPad2d(3));
  head->push_back(Conv(channels + (options_.input_skip ? options_.input_channels : 0), options_.output_channels, 7));
  if (options_.output_tanh) head->push_back(nn::Tanh());
  head_ = register_module("head", head);

  // pix2pix initialisation: N(0, 0.02) weights, zero biases.
  torch::NoGradGuard no_grad;
  for (auto& module : modules(/*include_self=*/false)) {
    if (auto* conv = module->as<nn::Conv2d>()) {
      conv->weight.normal_(0.0, 0.02);
      conv->bias.zero_();
    } else if (auto* deconv = module->as<nn::ConvTranspose2d>()) {
      deconv->weight.normal_(0.0, 0.02);
      deconv->bias.zero_();
    }
  }
}

torch::Tensor ResnetGeneratorImpl::forward(const torch::Tensor& x) {
  RELIT_REQUIRE(x.dim() == 4 && x.size(1) == options_.input_channels, "generator: input must be [B, ",
                options_.input_channels, ", H, W], got ", x.sizes());
  const int64_t factor = int64_t{1} << kDownsamplings;
  RELIT_REQUIRE(x.size(2) % factor == 0 && x.size(3) % factor == 0 && x.size(2) >= 2 * factor &&
                    x.size(3) >= 2 * factor,
                "generator: image size ", x.size(3), " x ", x.size(2), " must be a multiple of ", factor,
                " and at least ", 2 * factor, " (crop or pad the input)");
  const auto features = model_->forward(x);
  return head_->forward(options_.input_skip ? torch::cat({features, x}, 1) : features);
}

torch::Tensor BuildNetworkInput(const torch::Tensor& sampled_texture, const torch::Tensor& cues,
                                double max_radiance) {
  RELIT_REQUIRE(cues.dim() == 4 && cues.size(1) >= 3 && cues.size(1) % 3 == 0 &&
                    cues.size(0) == sampled_texture.size(0) && cues.size(2) == sampled_texture.size(2) &&
                    cues.size(3) == sampled_texture.size(3),
                "network input: cues must be [B, 3 N, H, W] matching the texture ", sampled_texture.sizes(),
                ", got ", cues.sizes());
  const int64_t bases = cues.size(1) / 3;
  RELIT_REQUIRE(sampled_texture.dim() == 4 && sampled_texture.size(1) % bases == 0,
                "network input: texture must be [B, ", bases, " C, H, W] for ", bases, " cue bases, got ",
                sampled_texture.sizes());
  const int64_t per_basis = sampled_texture.size(1) / bases;
  std::vector<int64_t> index;
  for (int64_t basis = 0; basis < bases; ++basis) {
    for (int64_t k = 0; k < per_basis; ++k) index.push_back(3 * basis + k % 3);
  }
  const auto index_tensor = torch::tensor(index, torch::TensorOptions().dtype(torch::kLong).device(cues.device()));
  const auto tiled = cues.to(sampled_texture.dtype()).index_select(1, index_tensor);
  return LogEncoding(max_radiance).Encode(sampled_texture * tiled);
}

torch::Tensor CueRegression(const torch::Tensor& weights, const torch::Tensor& cues) {
  RELIT_REQUIRE(cues.dim() == 4 && cues.size(1) % 3 == 0 && weights.sizes() == cues.sizes(),
                "cue regression: weights and cues must both be [B, 3 N, H, W], got ", weights.sizes(), " and ",
                cues.sizes());
  const auto products = weights * cues.to(weights.dtype());
  return products.view({cues.size(0), cues.size(1) / 3, 3, cues.size(2), cues.size(3)}).sum(1);
}

torch::Tensor BuildShNetworkInput(const torch::Tensor& sampled_texture, const torch::Tensor& sh,
                                  double max_radiance) {
  constexpr int64_t kDirections = 18, kLight = 21;  // shv + shl, + level RGB
  RELIT_REQUIRE(sh.dim() == 4 && sh.size(1) == kLight && sampled_texture.dim() == 4 &&
                    sampled_texture.size(1) > kLight && sh.size(0) == sampled_texture.size(0) &&
                    sh.size(2) == sampled_texture.size(2) && sh.size(3) == sampled_texture.size(3),
                "sh network input: texture [B, 21 + C, H, W] and sh channels [B, 21, H, W] expected, got ",
                sampled_texture.sizes(), " and ", sh.sizes());
  const auto light = sh.to(sampled_texture.dtype());
  const auto directions = sampled_texture.slice(1, 0, kDirections) * light.slice(1, 0, kDirections);
  const auto level = LogEncoding(max_radiance)
                         .Encode(sampled_texture.slice(1, kDirections, kLight) * light.slice(1, kDirections, kLight));
  return torch::cat({directions, level, sampled_texture.slice(1, kLight)}, 1);
}

}  // namespace relit::relight
