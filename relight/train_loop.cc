#include "relight/train_loop.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <limits>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "relight/checkpoint.h"
#include "relight/dataset.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::atomic<int> g_signal{0};
extern "C" void OnStopSignal(int signal) { g_signal.store(signal); }

// Installs SIGINT/SIGTERM handlers for the scope (training checkpoints and
// stops cleanly instead of dying mid-step).
class StopSignals {
 public:
  StopSignals() {
    g_signal.store(0);
    previous_int_ = std::signal(SIGINT, OnStopSignal);
    previous_term_ = std::signal(SIGTERM, OnStopSignal);
  }
  ~StopSignals() {
    std::signal(SIGINT, previous_int_);
    std::signal(SIGTERM, previous_term_);
  }
  int received() const { return g_signal.load(); }

 private:
  void (*previous_int_)(int);
  void (*previous_term_)(int);
};

}  // namespace

int FrameOrder::At(int64_t step) {
  const int64_t epoch = step / count_;
  if (epoch != epoch_) {
    auto generator = at::make_generator<at::CPUGeneratorImpl>(seed_ * 7919 + static_cast<uint64_t>(epoch) + 1);
    permutation_ = torch::randperm(count_, generator, torch::kLong);
    epoch_ = epoch;
  }
  return static_cast<int>(permutation_[step % count_].item<int64_t>());
}

Batch Concatenate(const std::vector<const Batch*>& frames) {
  if (frames.size() == 1) return *frames[0];
  auto cat = [&](auto member) {
    std::vector<torch::Tensor> parts;
    for (const Batch* b : frames) parts.push_back(b->*member);
    return torch::cat(parts, 0);
  };
  Batch batch;
  batch.uv = cat(&Batch::uv);
  batch.uv_derivatives = cat(&Batch::uv_derivatives);
  batch.coverage = cat(&Batch::coverage);
  batch.cues = cat(&Batch::cues);
  batch.target_rgb = cat(&Batch::target_rgb);
  batch.target_matte = cat(&Batch::target_matte);
  return batch;
}

namespace {

// A held-out frame's photo (clipped at the capture's white level) and matte,
// what a render of the frame is scored against.
struct HeldOutPhoto {
  Image target, matte;
};

HeldOutPhoto PhotoOf(const Batch& frame) {
  HeldOutPhoto photo{TensorToImage(frame.target_rgb, {"R", "G", "B"}), TensorToImage(frame.target_matte, {"A"})};
  ClipRadiance(&photo.target, kCaptureWhiteLevel);
  return photo;
}

ImageMetrics Score(Image predicted, const HeldOutPhoto& photo) {
  ClipRadiance(&predicted, kCaptureWhiteLevel);
  return CompareToReference(predicted, photo.target, photo.matte);
}

}  // namespace

ImageMetrics Validate(DnlModel& model, const std::vector<Batch>& frames) {
  std::vector<ImageMetrics> metrics;
  for (const Batch& frame : frames) metrics.push_back(Score(RenderFrame(model, frame), PhotoOf(frame)));
  return PoolMetrics(metrics);
}

nlohmann::json CorrectionChoice::ToJson() const {
  auto metrics = [](const ImageMetrics& m) {
    return nlohmann::json{{"psnr_db", m.psnr_db}, {"mae", m.mae}, {"alpha_mae", m.alpha_mae}};
  };
  return {{"renderer_kept", renderer_kept}, {"mask_kept", mask_kept},         {"trained", metrics(trained)},
          {"without_mask", metrics(without_mask)}, {"without_renderer", metrics(without_renderer)},
          {"chosen", metrics(chosen)}};
}

CorrectionChoice KeepHelpfulCorrections(DnlModel& model, const std::vector<Batch>& validation) {
  RELIT_REQUIRE(model->options().residual() && !validation.empty(),
                "KeepHelpfulCorrections needs the residual model and validation frames");
  torch::NoGradGuard no_grad;
  std::vector<torch::Tensor> gates = model->gates();  // renderer, mask (sharing the parameters' storage)
  const torch::Tensor renderer_gate = gates[0].detach().clone(), mask_gate = gates[1].detach().clone();
  CorrectionChoice choice;
  choice.trained = Validate(model, validation);
  gates[1].zero_();
  // Without a mask network its gate changes nothing: no second pass.
  choice.without_mask = model->has_mask_net() ? Validate(model, validation) : choice.trained;
  choice.mask_kept = choice.trained.alpha_mae < choice.without_mask.alpha_mae;
  if (choice.mask_kept) gates[1].copy_(mask_gate);
  const ImageMetrics& with_renderer = choice.mask_kept ? choice.trained : choice.without_mask;
  gates[0].zero_();
  choice.without_renderer = Validate(model, validation);
  choice.renderer_kept = with_renderer.psnr_db > choice.without_renderer.psnr_db;
  if (choice.renderer_kept) gates[0].copy_(renderer_gate);
  choice.chosen = choice.renderer_kept ? with_renderer : choice.without_renderer;
  return choice;
}

nlohmann::json OutputBlurChoice::ToJson() const {
  nlohmann::json tried_json = nlohmann::json::array();
  for (const auto& [sigma, m] : tried) tried_json.push_back({{"texels", sigma}, {"psnr_db", m.psnr_db}, {"mae", m.mae}});
  return {{"chosen_texels", chosen_texels},
          {"best_texels", best_texels},
          {"tried", tried_json},
          {"frame_shift_px_median", median_shift_px}};
}

namespace {

// x [1, C, H, W] with its content moved by (dx, dy) pixels (x right, y
// down): bicubic, zero outside (the frame's border is far from the object).
torch::Tensor Shifted(const torch::Tensor& x, double dx, double dy) {
  if (dx == 0 && dy == 0) return x;
  const int64_t h = x.size(2), w = x.size(3);
  const auto options = x.options();
  // Normalised coordinates (align_corners false) of the source of each pixel.
  const auto xs = (torch::arange(w, options) + 0.5 - dx) * (2.0 / w) - 1.0;
  const auto ys = (torch::arange(h, options) + 0.5 - dy) * (2.0 / h) - 1.0;
  const auto grid = torch::stack({xs.view({1, w}).expand({h, w}), ys.view({h, 1}).expand({h, w})}, -1).unsqueeze(0);
  // at::grid_sampler's modes: interpolation 2 = bicubic, padding 0 = zeros.
  return torch::grid_sampler(x, grid, /*interpolation_mode=*/2, /*padding_mode=*/0, /*align_corners=*/false);
}

cv::Mat Luminance(const torch::Tensor& rgb, int64_t top, int64_t left, int64_t height, int64_t width) {
  const auto crop = rgb.slice(2, top, top + height).slice(3, left, left + width).mean(1)[0].contiguous().to(torch::kFloat);
  return cv::Mat(static_cast<int>(height), static_cast<int>(width), CV_32F, crop.data_ptr<float>()).clone();
}

// How far the held-out frame's image sits from the model's render of it,
// over the object's window (phase correlation of the luminances): its
// calibrated pose's error, which new views do not have. Zero when the
// estimate is beyond max_px (no reliable peak).
cv::Point2d FrameShift(const torch::Tensor& render, const Batch& frame, double max_px = 2.0) {
  int64_t top = 0, left = 0;
  const Batch window = ObjectWindow(frame, 8, &top, &left);
  if (window.height() < 16 || window.width() < 16) return {0, 0};
  const cv::Mat rendered = Luminance(render.slice(1, 0, 3), top, left, window.height(), window.width());
  const cv::Mat photo = Luminance(frame.target_rgb * frame.target_matte, top, left, window.height(), window.width());
  cv::Mat hann;
  cv::createHanningWindow(hann, rendered.size(), CV_32F);
  const cv::Point2d shift = cv::phaseCorrelate(rendered, photo, hann);
  return std::hypot(shift.x, shift.y) <= max_px ? shift : cv::Point2d(0, 0);
}

}  // namespace

size_t NarrowestWithinOneStandardError(const std::vector<std::vector<ImageMetrics>>& per_frame) {
  RELIT_REQUIRE(!per_frame.empty() && !per_frame[0].empty(), "no candidates or no frames to choose from");
  const size_t frames = per_frame[0].size();
  int64_t pixels = 0;
  for (const ImageMetrics& m : per_frame[0]) pixels += m.foreground_pixels;
  // Frame f's share of candidate c's pooled MSE (PoolMetrics), times the
  // number of frames: the pooled MSE is the mean of these over the frames.
  const auto share = [&](size_t c, size_t f) {
    return static_cast<double>(frames) * per_frame[c][f].mse * per_frame[c][f].foreground_pixels /
           std::max<int64_t>(pixels, 1);
  };
  size_t best = 0;
  for (size_t c = 1; c < per_frame.size(); ++c) {
    if (PoolMetrics(per_frame[c]).mse < PoolMetrics(per_frame[best]).mse) best = c;
  }
  if (frames < 2) return best;
  for (size_t c = 0; c < best; ++c) {
    // Paired over the frames: how much worse c is than the best, and that
    // difference's standard error.
    double mean = 0, square = 0;
    for (size_t f = 0; f < frames; ++f) {
      const double d = share(c, f) - share(best, f);
      mean += d, square += d * d;
    }
    mean /= frames;
    const double variance = std::max(0.0, (square - frames * mean * mean) / (frames - 1));
    if (mean <= std::sqrt(variance / frames)) return c;
  }
  return best;
}

OutputBlurChoice ChooseOutputBlur(DnlModel& model, const std::vector<Batch>& validation) {
  RELIT_REQUIRE(model->options().residual() && !validation.empty(),
                "ChooseOutputBlur needs the residual model and validation frames");
  torch::NoGradGuard no_grad;
  model->set_output_blur_texels(0);
  // One network pass per frame; the blurs are applied to it. Each render is
  // first moved onto its held-out photo by the frame's shift, so that the
  // blur answers for the proxy's error and not for the frame's pose.
  const int64_t resolution = model->options().texture_resolution_px;
  std::vector<torch::Tensor> renders, moved;
  std::vector<HeldOutPhoto> photos;
  std::vector<double> shifts;
  for (const Batch& frame : validation) {
    renders.push_back(RenderFrameTensor(model, frame));
    photos.push_back(PhotoOf(frame));
    const cv::Point2d shift = FrameShift(renders.back(), frame);
    shifts.push_back(std::hypot(shift.x, shift.y));
    moved.push_back(Shifted(renders.back(), shift.x, shift.y).clamp_min(0));
  }
  // The scores of `frames` (renders of the held-out frames) blurred by `sigma` texels, per frame.
  const auto score = [&](const std::vector<torch::Tensor>& frames, double sigma) {
    std::vector<ImageMetrics> metrics;
    for (size_t i = 0; i < validation.size(); ++i) {
      metrics.push_back(
          Score(TensorToImage(BlurWithinCoverage(frames[i], validation[i], sigma, resolution), {"R", "G", "B", "A"}),
                photos[i]));
    }
    return metrics;
  };
  OutputBlurChoice choice;
  std::nth_element(shifts.begin(), shifts.begin() + shifts.size() / 2, shifts.end());
  choice.median_shift_px = shifts[shifts.size() / 2];
  std::vector<std::vector<ImageMetrics>> per_frame;
  for (const double sigma : OutputBlurCandidates()) {
    per_frame.push_back(score(moved, sigma));
    choice.tried.emplace_back(sigma, PoolMetrics(per_frame.back()));
  }
  const size_t chosen = NarrowestWithinOneStandardError(per_frame);
  choice.chosen_texels = choice.tried[chosen].first;
  choice.best_texels = std::min_element(choice.tried.begin(), choice.tried.end(), [](const auto& a, const auto& b) {
                         return a.second.mse < b.second.mse;
                       })->first;
  choice.moved = choice.tried[chosen].second;
  choice.unmoved = PoolMetrics(score(renders, choice.chosen_texels));
  model->set_output_blur_texels(choice.chosen_texels);
  return choice;
}

void TruncateLog(const fs::path& log, int64_t step) {
  if (!fs::exists(log)) return;
  std::ifstream in(log);
  std::ostringstream kept;
  std::string line;
  while (std::getline(in, line)) {
    const json j = json::parse(line, nullptr, false);
    if (!j.is_discarded() && j.contains("step") && j["step"].get<int64_t>() <= step) kept << line << "\n";
  }
  AtomicWriteFile(log, kept.str());
}

TrainLoopResult RunTrainLoop(Trainer& trainer, const std::function<Batch(int64_t)>& next_batch,
                             const std::vector<Batch>& validation, const TrainLoopSettings& settings,
                             const std::function<std::string(int64_t)>& tag) {
  TrainLoopResult result;
  std::ofstream log(settings.log_path, std::ios::app);
  StopSignals signals;
  const int64_t total = settings.total_steps;
  Progress progress(settings.label, total - std::min(trainer.step(), total));
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return SecondsSince(start); };
  auto validate = [&](int64_t step) {
    if (validation.empty()) return;
    result.validation = Validate(trainer.model(), validation);
    const ImageMetrics& m = result.validation;
    log << json{{"step", step}, {"val_psnr_db", m.psnr_db}, {"val_mae", m.mae}, {"val_alpha_mae", m.alpha_mae}}.dump()
        << "\n" << std::flush;
  };
  double loss_sum = 0;
  int loss_count = 0;
  while (trainer.step() < total) {
    const std::string kind = tag ? tag(trainer.step()) : std::string();
    const Losses losses = trainer.Step(next_batch(trainer.step()));
    const int64_t step = trainer.step();
    const double loss = losses.total.item<double>();
    RELIT_REQUIRE(std::isfinite(loss), settings.label, ": the loss became ", loss, " at step ", step,
                  "; lower train.learning_rate or check the input frames");
    loss_sum += loss;
    ++loss_count;
    result.final_loss = loss;
    if (step % settings.log_every == 0 || step == total) {
      json line = {{"step", step}, {"time_s", elapsed()}, {"loss", loss_sum / loss_count},
                   {"rgb_loss", losses.rgb.item<double>()}, {"mask_loss", losses.mask.item<double>()}};
      if (!kind.empty()) line["batch"] = kind;
      log << line.dump() << "\n" << std::flush;
      char status[64];
      std::snprintf(status, sizeof(status), "loss %.4f", loss_sum / loss_count);
      progress.SetStatus(status);
      loss_sum = 0;
      loss_count = 0;
    }
    if (settings.validate_every > 0 && step % settings.validate_every == 0 && step != total) validate(step);
    progress.Advance();
    if (step % settings.checkpoint_every == 0 || step == total || signals.received() != 0) {
      SaveCheckpoint(settings.checkpoint_dir, trainer);
    }
    if (signals.received() != 0) {
      result.interrupted = true;
      result.signal = signals.received();
      break;
    }
  }
  progress.Finish();
  if (!result.interrupted) validate(trainer.step());
  return result;
}

}  // namespace relit::relight
