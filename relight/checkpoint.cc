#include "relight/checkpoint.h"

#include <exception>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/options.h"

namespace relit::relight {
namespace {

constexpr const char* kModelFile = "model.pt";
constexpr const char* kOptimizerFile = "optimizer.pt";
constexpr const char* kRngFile = "rng.pt";
constexpr const char* kInfoFile = "checkpoint.json";

// Runs a LibTorch load/save and turns its c10::Error into a relit::Error
// naming the file.
template <typename Fn>
void WithTorchErrors(const std::filesystem::path& path, const char* what, Fn fn) {
  try {
    fn();
  } catch (const c10::Error& e) {
    Fail("checkpoint: cannot ", what, " ", path.string(), ": ", e.what_without_backtrace());
  }
}

// The format keys ("input", "bases") are not `model:` options: split them off.
ModelOptions ModelOptionsFromJson(const nlohmann::json& j_in, const std::string& where) {
  nlohmann::json j = j_in, format = nlohmann::json::object();
  // Checkpoints from before the variants hold the DNL model.
  if (j.is_object() && !j.contains("variant")) j["variant"] = "dnl";
  // Residual checkpoints from before the smooth fit read their weights per texel.
  if (j.is_object() && !j.contains("cue_fit")) j["cue_fit"] = "per_texel";
  if (j.is_object() && !j.contains("object_window_margin_px")) j["object_window_margin_px"] = 0;
  if (j.is_object() && !j.contains("mask_band_px")) j["mask_band_px"] = 0;  // alpha over the whole frame
  if (j.is_object() && !j.contains("mask_correction")) j["mask_correction"] = true;  // they hold a mask network
  if (j.is_object() && !j.contains("output_blur_texels")) j["output_blur_texels"] = 0;  // rendered unblurred
  for (const char* key : {"input", "bases"}) {
    if (j.is_object() && j.contains(key)) {
      format[key] = j[key];
      j.erase(key);
    }
  }
  OptionsReader reader = OptionsReader::FromString(j.dump(), where);
  ModelOptions options;
  ReadOptions(reader, &options);
  options.format = CueFormat::FromJson(format, where);  // absent: the default (older checkpoints)
  CheckOptions(options, where);
  return options;
}

TrainOptions TrainOptionsFromJson(const nlohmann::json& j_in, const std::string& where) {
  // Keys a checkpoint predates read as what it trained with, not as
  // today's defaults: before clip_model, clipped readings were lifted.
  nlohmann::json j = j_in;
  if (j.contains("cue_fit") && j["cue_fit"].is_object() && !j["cue_fit"].contains("clip_model")) {
    j["cue_fit"]["clip_model"] = "lift";
  }
  OptionsReader reader = OptionsReader::FromString(j.dump(), where);
  TrainOptions options;
  ReadOptions(reader, &options);
  CheckOptions(options, where);
  return options;
}

}  // namespace

void SaveCheckpoint(const std::filesystem::path& dir, Trainer& trainer) {
  AtomicDir out(dir);
  const auto model_path = out.path() / kModelFile;
  const auto optimizer_path = out.path() / kOptimizerFile;
  const auto rng_path = out.path() / kRngFile;
  WithTorchErrors(model_path, "write", [&] { torch::save(trainer.model(), model_path.string()); });
  WithTorchErrors(optimizer_path, "write", [&] { torch::save(trainer.optimizer(), optimizer_path.string()); });
  WithTorchErrors(rng_path, "write", [&] { torch::save(trainer.generator().get_state(), rng_path.string()); });
  nlohmann::json body = {
      {"step", trainer.step()},
      {"clip_overshoot", trainer.clip_overshoot()},
      {"clip_noise", trainer.clip_noise()},
      {"output_blur_texels", trainer.model()->output_blur_texels()},
      {"model_options", OptionsToJson(trainer.model()->options())},
      {"train_options", OptionsToJson(trainer.train_options())},
      {"torch_version", TORCH_VERSION},
      {"files", {{"model", kModelFile}, {"optimizer", kOptimizerFile}, {"rng", kRngFile}}},
  };
  WriteJsonFile((out.path() / kInfoFile).string(), CheckpointInfo::kKind, CheckpointInfo::kVersion, body);
  out.Commit();
}

CheckpointInfo ReadCheckpointInfo(const std::filesystem::path& dir) {
  const std::string path = (dir / kInfoFile).string();
  const nlohmann::json j = ReadJsonFile(path, CheckpointInfo::kKind, CheckpointInfo::kVersion);
  CheckpointInfo info;
  const nlohmann::json& step = JsonField(j, "step", path);
  RELIT_REQUIRE(step.is_number_integer() && step.get<int64_t>() >= 0, path,
                ": 'step' must be a non-negative integer");
  info.step = step.get<int64_t>();
  // Checkpoints from before the lift trained with the readings as the bound.
  if (j.contains("clip_overshoot")) {
    const nlohmann::json& lift = j["clip_overshoot"];
    RELIT_REQUIRE(lift.is_number() && lift.get<double>() >= 1, path, ": 'clip_overshoot' must be a number >= 1");
    info.clip_overshoot = lift.get<double>();
  }
  if (j.contains("clip_noise")) {  // absent before the censored model: bounds
    const nlohmann::json& noise = j["clip_noise"];
    RELIT_REQUIRE(noise.is_number() && noise.get<double>() >= 0, path, ": 'clip_noise' must be a number >= 0");
    info.clip_noise = noise.get<double>();
  }
  if (j.contains("output_blur_texels")) {  // absent before the output blur: none
    const nlohmann::json& blur = j["output_blur_texels"];
    RELIT_REQUIRE(blur.is_number() && blur.get<double>() >= 0, path,
                  ": 'output_blur_texels' must be a number >= 0");
    info.output_blur_texels = blur.get<double>();
  }
  info.model_options = ModelOptionsFromJson(JsonField(j, "model_options", path), path + " model_options");
  info.train_options = TrainOptionsFromJson(JsonField(j, "train_options", path), path + " train_options");
  return info;
}

std::unique_ptr<Trainer> LoadTrainer(const std::filesystem::path& dir, const std::string& device) {
  CheckpointInfo info = ReadCheckpointInfo(dir);
  if (!device.empty()) info.model_options.device = device;
  auto trainer = std::make_unique<Trainer>(info.model_options, info.train_options);
  const torch::Device target = trainer->model()->device();
  const auto model_path = dir / kModelFile;
  const auto optimizer_path = dir / kOptimizerFile;
  const auto rng_path = dir / kRngFile;
  WithTorchErrors(model_path, "read", [&] { torch::load(trainer->model(), model_path.string(), target); });
  WithTorchErrors(optimizer_path, "read",
                  [&] { torch::load(trainer->optimizer(), optimizer_path.string(), target); });
  torch::Tensor rng_state;
  WithTorchErrors(rng_path, "read", [&] {
    torch::load(rng_state, rng_path.string());
    trainer->generator().set_state(rng_state);
  });
  trainer->set_step(info.step);
  trainer->set_clip_overshoot(info.clip_overshoot);
  trainer->set_clip_noise(info.clip_noise);
  trainer->model()->set_output_blur_texels(info.output_blur_texels);
  return trainer;
}

DnlModel LoadModel(const std::filesystem::path& dir, const std::string& device) {
  CheckpointInfo info = ReadCheckpointInfo(dir);
  if (!device.empty()) info.model_options.device = device;
  DnlModel model(info.model_options);
  const auto model_path = dir / kModelFile;
  WithTorchErrors(model_path, "read", [&] { torch::load(model, model_path.string(), model->device()); });
  model->set_output_blur_texels(info.output_blur_texels);
  return model;
}

void RequireCheckpointFormat(const std::filesystem::path& dir, const CueFormat& configured) {
  const CueFormat trained = ReadCheckpointInfo(dir).model_options.format;
  RELIT_REQUIRE(trained == configured, "the model in ", dir.string(), " was trained on ", trained.Describe(),
                " but the config asks for ", configured.Describe(),
                ": use the config it was trained with, or rerun cues, plan and train with this one");
}

}  // namespace relit::relight
