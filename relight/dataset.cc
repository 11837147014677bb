#include "relight/dataset.h"

#include <algorithm>
#include <filesystem>

#include "core/error.h"
#include "relight/cue_frames.h"

namespace relit::relight {

namespace F = torch::nn::functional;

namespace {

// Channels [first, first + count) of an image as a [H, W, count] tensor.
torch::Tensor Channels(const Image& image, int first, int count) {
  const auto all = torch::from_blob(const_cast<float*>(image.data().data()),
                                    {image.height(), image.width(), image.channels()}, torch::kFloat32);
  return all.slice(2, first, first + count).clone();
}

}  // namespace

Batch CueFrameToBatch(const Image& cue_frame, const CueFormat& format) {
  RELIT_REQUIRE(cue_frame.channel_names() == format.Channels(), "cue frame: unexpected channels for ",
                format.Describe(), " (rendered with other cues.input / cues.bases settings, or by an older relit? "
                "rerun `relit-relight cues`)");
  const int light = format.light_channels();
  Batch batch;
  batch.cues = Channels(cue_frame, 0, light).permute({2, 0, 1}).unsqueeze(0).contiguous();
  batch.uv = Channels(cue_frame, light, 2).unsqueeze(0);
  batch.uv_derivatives = Channels(cue_frame, light + 2, 4).unsqueeze(0);
  batch.coverage = Channels(cue_frame, light + 6, 1).permute({2, 0, 1}).unsqueeze(0).contiguous();
  return batch;
}

Batch LoadPlanFrame(const std::string& workspace, const PlanFrame& frame, const CueFormat& format) {
  const std::filesystem::path root(workspace);
  const Image cues = ReadCueFrame((root / frame.cues).string(), format);
  const Image target = ReadImage((root / frame.image).string());
  const Image matte = ReadImage((root / frame.matte).string());
  RELIT_REQUIRE(target.channels() >= 3, frame.image, ": expected an RGB image");
  RELIT_REQUIRE(cues.width() == target.width() && cues.height() == target.height() &&
                    matte.width() == target.width() && matte.height() == target.height(),
                "frame ", frame.name, ": cue frame ", frame.cues, " (", cues.width(), "x", cues.height(),
                "), image ", frame.image, " (", target.width(), "x", target.height(), ") and matte ", frame.matte,
                " (", matte.width(), "x", matte.height(), ") must have the same size; rerun `relit-relight cues`");
  Batch batch = CueFrameToBatch(cues, format);
  AttachTargets(batch, target, matte);
  return batch;
}

std::vector<Batch> LoadValidationFrames(const std::string& workspace, const Plan& plan, const PlanPartition& part,
                                        int max_frames, const CueFormat& format, double matte_threshold) {
  const int count = std::min<int>(max_frames, static_cast<int>(part.validation_frames.size()));
  std::vector<Batch> frames;
  for (int i = 0; i < count; ++i) {
    const size_t pick = part.validation_frames.size() * (2 * i + 1) / (2 * count);  // evenly spread
    frames.push_back(LoadPlanFrame(workspace, plan.frames[part.validation_frames[pick]], format));
  }
  ThresholdMattes(frames, matte_threshold);
  return frames;
}

void ThresholdMattes(std::vector<Batch>& frames, double threshold) {
  if (threshold <= 0) return;
  for (Batch& f : frames) f.target_matte = (f.target_matte >= threshold).to(f.target_matte.dtype());
}

void AttachTargets(Batch& batch, const Image& rgb, const Image& matte, int matte_channel) {
  batch.target_rgb = Channels(rgb, 0, 3).permute({2, 0, 1}).unsqueeze(0).contiguous();
  batch.target_matte =
      Channels(matte, matte_channel, 1).permute({2, 0, 1}).unsqueeze(0).contiguous().clamp(0.0, 1.0);
}

Image TensorToImage(const torch::Tensor& chw, std::vector<std::string> names) {
  const auto hwc = chw.squeeze(0).permute({1, 2, 0}).contiguous().to(torch::kCPU, torch::kFloat32);
  RELIT_CHECK(hwc.size(2) == static_cast<int64_t>(names.size()));
  Image image(static_cast<int>(hwc.size(1)), static_cast<int>(hwc.size(0)), std::move(names));
  std::memcpy(image.data().data(), hwc.data_ptr<float>(), image.data().size() * sizeof(float));
  return image;
}

Image RenderFrame(DnlModel& model, const Batch& batch) {
  return TensorToImage(RenderFrameTensor(model, batch), {"R", "G", "B", "A"});
}

torch::Tensor RenderFrameTensor(DnlModel& model, const Batch& batch) {
  const int64_t h = batch.height(), w = batch.width();
  const int64_t pad_h = (4 - h % 4) % 4, pad_w = (4 - w % 4) % 4;
  Batch padded = batch;
  if (pad_h > 0 || pad_w > 0) {
    auto pad_chw = [&](const torch::Tensor& t) { return F::pad(t, F::PadFuncOptions({0, pad_w, 0, pad_h})); };
    auto pad_hwc = [&](const torch::Tensor& t) {
      return F::pad(t.permute({0, 3, 1, 2}), F::PadFuncOptions({0, pad_w, 0, pad_h})).permute({0, 2, 3, 1});
    };
    padded.cues = pad_chw(batch.cues);
    padded.coverage = pad_chw(batch.coverage);
    padded.uv = pad_hwc(batch.uv).contiguous();
    padded.uv_derivatives = pad_hwc(batch.uv_derivatives).contiguous();
    padded.target_rgb = torch::Tensor();
    padded.target_matte = torch::Tensor();
  }
  model->eval();
  return model->Render(padded).slice(2, 0, h).slice(3, 0, w);
}

}  // namespace relit::relight
