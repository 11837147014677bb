// eval's outputs: SSIM, the per-type tables (eval.json, eval.md) and PNGs.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include <opencv2/imgproc.hpp>
#include <opencv2/quality/qualityssim.hpp>
#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/color.h"
#include "core/error.h"
#include "core/json_file.h"
#include "relight/eval.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr float kGreySrgb = 64.0f / 255.0f;  // the render stage's MP4 background (0x404040)

// Light types in table order; others (none today) follow in order of appearance.
std::vector<std::string> LightTypes(const std::vector<EvalImageResult>& results) {
  std::vector<std::string> types;
  for (const std::string t : {"point", "directional", "environment"}) {
    if (std::any_of(results.begin(), results.end(), [&](const EvalImageResult& r) { return r.light_type == t; })) {
      types.push_back(t);
    }
  }
  for (const EvalImageResult& r : results) {
    if (std::find(types.begin(), types.end(), r.light_type) == types.end()) types.push_back(r.light_type);
  }
  return types;
}

struct Pooled {
  ImageMetrics metrics;
  double ssim = std::numeric_limits<double>::quiet_NaN();  // mean over images with a foreground
  int images = 0;
};

// `light_type` "all" pools every light.
Pooled Pool(const std::vector<EvalImageResult>& results, const std::string& method, const std::string& light_type) {
  std::vector<ImageMetrics> metrics;
  double ssim_sum = 0;
  int ssim_count = 0;
  for (const EvalImageResult& r : results) {
    if (r.method != method || (light_type != "all" && r.light_type != light_type)) continue;
    metrics.push_back(r.metrics);
    if (std::isfinite(r.ssim)) {
      ssim_sum += r.ssim;
      ++ssim_count;
    }
  }
  Pooled p;
  p.images = static_cast<int>(metrics.size());
  if (!metrics.empty()) p.metrics = PoolMetrics(metrics);
  if (ssim_count > 0) p.ssim = ssim_sum / ssim_count;
  return p;
}

// JSON has no NaN/Inf: null instead.
json Number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json MetricsJson(const ImageMetrics& m, double ssim) {
  return {{"psnr_db", Number(m.psnr_db)}, {"mae", Number(m.mae)},         {"mse", Number(m.mse)},
          {"ssim", Number(ssim)},         {"alpha_mae", Number(m.alpha_mae)}, {"foreground_pixels", m.foreground_pixels}};
}

std::string Cell(const Pooled& p) {
  if (p.images == 0) return "–";
  return fmt::format("{:.2f} / {:.4f} / {:.3f}", p.metrics.psnr_db, p.metrics.mae, p.ssim);
}

// A score this close to the truth's noise floor measures the truth's noise
// as much as the method (issue 24: claimed scores stay >= 6 dB below it).
constexpr double kMinFloorMarginDb = 6.0;

// The floor's PSNR minus the score's, NaN without a floor.
double FloorMarginDb(const Pooled& score, const Pooled& floor) {
  if (score.images == 0 || floor.images == 0) return std::numeric_limits<double>::quiet_NaN();
  return floor.metrics.psnr_db - score.metrics.psnr_db;
}

// The cell, marked "*" when it lies within kMinFloorMarginDb of its floor.
std::string CellAgainstFloor(const Pooled& p, const Pooled& floor) {
  const double margin = FloorMarginDb(p, floor);
  return Cell(p) + (std::isfinite(margin) && margin < kMinFloorMarginDb ? " *" : "");
}

// eval.json rows: "truth_floor_margin_db" when the truth has a floor.
void AddFloorMargin(const Pooled& p, const Pooled& floor, json* row, int* close_to_floor) {
  const double margin = FloorMarginDb(p, floor);
  if (!std::isfinite(margin)) return;
  (*row)["truth_floor_margin_db"] = margin;
  *close_to_floor += margin < kMinFloorMarginDb;
}

// "| method | type... | all | alpha MAE |" rows, then the truth's noise floor.
void AppendMethodTable(std::string* out, const std::vector<EvalImageResult>& results,
                       const std::vector<EvalImageResult>& floors, const std::vector<std::string>& methods,
                       const std::vector<std::string>& types, double clip) {
  std::string& md = *out;
  md += clip > 0 ? fmt::format("| method (clip {:g}) |", clip) : std::string("| method (no clip) |");
  for (const std::string& t : types) md += " " + t + " |";
  md += " all | alpha MAE |\n|---|";
  for (size_t i = 0; i < types.size() + 2; ++i) md += "---|";
  md += "\n";
  for (const std::string& method : methods) {
    md += "| " + method + " |";
    for (const std::string& t : types) {
      md += " " + CellAgainstFloor(Pool(results, method, t), Pool(floors, kTruthNoiseFloor, t)) + " |";
    }
    const Pooled all = Pool(results, method, "all");
    md += " " + CellAgainstFloor(all, Pool(floors, kTruthNoiseFloor, "all")) + " | " +
          fmt::format("{:.4f}", all.metrics.alpha_mae) + " |\n";
  }
  if (!floors.empty()) {
    md += "| truth noise floor |";
    for (const std::string& t : types) md += " " + Cell(Pool(floors, kTruthNoiseFloor, t)) + " |";
    md += " " + Cell(Pool(floors, kTruthNoiseFloor, "all")) + " | |\n";
  }
}

// View sets present, interpolation first.
std::vector<std::string> ViewSets(const std::vector<EvalImageResult>& results) {
  std::vector<std::string> sets;
  for (const std::string s : {"interpolation", "extrapolation"}) {
    if (std::any_of(results.begin(), results.end(), [&](const EvalImageResult& r) { return r.view_set == s; })) {
      sets.push_back(s);
    }
  }
  return sets;
}

std::vector<EvalImageResult> InViewSet(const std::vector<EvalImageResult>& results, const std::string& set) {
  std::vector<EvalImageResult> out;
  for (const EvalImageResult& r : results) {
    if (r.view_set == set) out.push_back(r);
  }
  return out;
}

}  // namespace

double ForegroundSsim(const Image& predicted, const Image& reference_rgb, const Image& matte) {
  RELIT_REQUIRE(predicted.channels() >= 4 && reference_rgb.channels() >= 3 && matte.channels() >= 1,
                "ForegroundSsim: expected RGBA, RGB and a matte");
  RELIT_REQUIRE(predicted.width() == reference_rgb.width() && predicted.height() == reference_rgb.height() &&
                    matte.width() == predicted.width() && matte.height() == predicted.height(),
                "ForegroundSsim: image sizes differ");
  int x0 = predicted.width(), y0 = predicted.height(), x1 = -1, y1 = -1;
  for (int y = 0; y < matte.height(); ++y) {
    for (int x = 0; x < matte.width(); ++x) {
      if (matte.at(x, y, 0) < 0.5f) continue;
      x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
    }
  }
  if (x1 < 0) return std::numeric_limits<double>::quiet_NaN();
  const int w = x1 - x0 + 1, h = y1 - y0 + 1;
  // OpenCV's QualitySSIM fixes C1 = (0.01 * 255)^2 and C2 = (0.03 * 255)^2 for
  // 8-bit data: scaling linear values by 255 makes the dynamic range L = 1.
  cv::Mat a(h, w, CV_32FC3), b(h, w, CV_32FC3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float* p = predicted.pixel(x0 + x, y0 + y);
      const float* r = reference_rgb.pixel(x0 + x, y0 + y);
      const float m = matte.at(x0 + x, y0 + y, 0);
      for (int c = 0; c < 3; ++c) {
        a.at<cv::Vec3f>(y, x)[c] = 255.0f * p[c];
        b.at<cv::Vec3f>(y, x)[c] = 255.0f * r[c] * m;
      }
    }
  }
  const cv::Scalar ssim = cv::quality::QualitySSIM::compute(b, a, cv::noArray());
  return (ssim[0] + ssim[1] + ssim[2]) / 3.0;
}

namespace {

// One premultiplied linear RGBA pixel over the grey background, sRGB-encoded into png(x, y).
void OverGreySrgb(const float* rgba, Image& png, int x, int y) {
  static const float grey = SrgbToLinear(kGreySrgb);
  const float a = std::clamp(rgba[3], 0.0f, 1.0f);
  for (int c = 0; c < 3; ++c) png.at(x, y, c) = LinearToSrgb(std::clamp(rgba[c] + (1 - a) * grey, 0.0f, 1.0f));
}

}  // namespace

void WriteRenderPng(const std::string& path, const Image& rgba) {
  Image png(rgba.width(), rgba.height(), {"R", "G", "B"});
  for (int y = 0; y < rgba.height(); ++y) {
    for (int x = 0; x < rgba.width(); ++x) OverGreySrgb(rgba.pixel(x, y), png, x, y);
  }
  WriteImage(path, png, PixelStorage::kUint8);
}

Image PremultipliedByMatte(const Image& rgb, const Image& matte) {
  Image rgba(rgb.width(), rgb.height(), {"R", "G", "B", "A"});
  for (int y = 0; y < rgba.height(); ++y) {
    for (int x = 0; x < rgba.width(); ++x) {
      const float m = std::clamp(matte.at(x, y, 0), 0.0f, 1.0f);
      for (int c = 0; c < 3; ++c) rgba.at(x, y, c) = rgb.at(x, y, c) * m;
      rgba.at(x, y, 3) = m;
    }
  }
  return rgba;
}

void WriteReferencePng(const std::string& path, const Image& reference_rgb, const Image& matte) {
  WriteRenderPng(path, PremultipliedByMatte(reference_rgb, matte));
}

void WriteErrorPng(const std::string& path, const Image& rgba, const Image& reference_rgb, const Image& matte,
                   double scale) {
  Image png(rgba.width(), rgba.height(), {"R", "G", "B"});
  for (int y = 0; y < rgba.height(); ++y) {
    for (int x = 0; x < rgba.width(); ++x) {
      const float m = matte.at(x, y, 0);
      for (int c = 0; c < 3; ++c) {
        const float error = std::abs(rgba.at(x, y, c) - reference_rgb.at(x, y, c) * m);
        png.at(x, y, c) = std::clamp(static_cast<float>(scale) * error, 0.0f, 1.0f);
      }
    }
  }
  WriteImage(path, png, PixelStorage::kUint8);
}

bool WriteZoomStripPng(const std::string& path, const Image& reference_rgb, const Image& matte,
                       const std::vector<const Image*>& renders, int height_px) {
  // The foreground's bounding box, 15 % larger on each side.
  int x0 = matte.width(), y0 = matte.height(), x1 = -1, y1 = -1;
  for (int y = 0; y < matte.height(); ++y) {
    for (int x = 0; x < matte.width(); ++x) {
      if (matte.at(x, y, 0) < 0.5f) continue;
      x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
    }
  }
  if (x1 < 0) return false;
  const int margin = static_cast<int>(0.15 * std::max(x1 - x0 + 1, y1 - y0 + 1)) + 1;
  x0 = std::max(0, x0 - margin), y0 = std::max(0, y0 - margin);
  x1 = std::min(matte.width() - 1, x1 + margin), y1 = std::min(matte.height() - 1, y1 + margin);
  const int crop_w = x1 - x0 + 1, crop_h = y1 - y0 + 1;
  const int zoom = std::max(1, height_px / crop_h);  // whole pixels: no resampling blur
  const Image rgba_reference = PremultipliedByMatte(reference_rgb, matte);
  std::vector<const Image*> panels = {&rgba_reference};
  panels.insert(panels.end(), renders.begin(), renders.end());
  const int gap = 4;
  Image png(static_cast<int>(panels.size()) * (crop_w * zoom + gap) - gap, crop_h * zoom, {"R", "G", "B"}, 1.0f);
  for (size_t i = 0; i < panels.size(); ++i) {
    const int left = static_cast<int>(i) * (crop_w * zoom + gap);
    for (int y = 0; y < crop_h * zoom; ++y) {
      for (int x = 0; x < crop_w * zoom; ++x) OverGreySrgb(panels[i]->pixel(x0 + x / zoom, y0 + y / zoom), png, left + x, y);
    }
  }
  WriteImage(path, png, PixelStorage::kUint8);
  return true;
}

void WriteEvalReport(const std::string& out_dir, const std::vector<EvalImageResult>& results,
                     const std::vector<std::string>& methods, json header,
                     const std::vector<EvalImageResult>& floors) {
  const std::vector<std::string> types = LightTypes(results);
  json summary = json::array();
  int close_to_floor = 0;  // pooled scores within kMinFloorMarginDb of their floor
  for (const std::string& method : methods) {
    std::vector<std::string> columns = types;
    columns.push_back("all");
    for (const std::string& type : columns) {
      const Pooled p = Pool(results, method, type);
      json row = {{"method", method}, {"light_type", type}, {"images", p.images}};
      row.update(MetricsJson(p.metrics, p.ssim));
      AddFloorMargin(p, Pool(floors, kTruthNoiseFloor, type), &row, &close_to_floor);
      summary.push_back(row);
    }
  }
  json images = json::array();
  for (const EvalImageResult& r : results) {
    json row = {{"view", r.view},     {"view_set", r.view_set}, {"light", r.light},
                {"light_type", r.light_type}, {"method", r.method}};
    row.update(MetricsJson(r.metrics, r.ssim));
    if (!r.render_png.empty()) {
      row["render_png"] = r.render_png;
      row["error_png"] = r.error_png;
      row["reference_png"] = r.reference_png;
    }
    images.push_back(row);
  }
  if (!floors.empty()) {
    json floor_rows = json::object();
    std::vector<std::string> columns = types;
    columns.push_back("all");
    for (const std::string& type : columns) {
      const Pooled p = Pool(floors, kTruthNoiseFloor, type);
      if (p.images > 0) floor_rows[type] = {{"psnr_db", p.metrics.psnr_db}, {"mae", p.metrics.mae}, {"images", p.images}};
    }
    json per_image = json::array();
    for (const EvalImageResult& r : floors) {
      per_image.push_back({{"view", r.view}, {"light", r.light}, {"psnr_db", r.metrics.psnr_db}});
    }
    header["truth_noise_floor"] = {
        {"note", "the truth against one of its two independent halves (or its twin, MSE halved): the score a perfect "
                 "prediction of the converged image gets; claimed scores should stay >= 6 dB below it"},
        {"per_light_type", floor_rows},
        {"images", per_image}};
  }
  json by_set = json::array();
  for (const std::string& set : ViewSets(results)) {
    const std::vector<EvalImageResult> in_set = InViewSet(results, set), floors_in_set = InViewSet(floors, set);
    std::vector<std::string> columns = types;
    columns.push_back("all");
    for (const std::string& method : methods) {
      for (const std::string& type : columns) {
        const Pooled p = Pool(in_set, method, type);
        json row = {{"view_set", set}, {"method", method}, {"light_type", type}, {"images", p.images}};
        row.update(MetricsJson(p.metrics, p.ssim));
        AddFloorMargin(p, Pool(floors_in_set, kTruthNoiseFloor, type), &row, &close_to_floor);
        by_set.push_back(row);
      }
    }
    for (const std::string& type : columns) {
      const Pooled p = Pool(floors_in_set, kTruthNoiseFloor, type);
      if (p.images == 0) continue;
      json row = {{"view_set", set}, {"method", kTruthNoiseFloor}, {"light_type", type}, {"images", p.images}};
      row.update(MetricsJson(p.metrics, p.ssim));
      by_set.push_back(row);
    }
  }
  header["summary_by_view_set"] = by_set;
  if (header.contains("truth_noise_floor")) {
    header["truth_noise_floor"]["min_margin_db"] = kMinFloorMarginDb;
    header["truth_noise_floor"]["scores_within_min_margin"] = close_to_floor;
  }
  header["light_types"] = types;
  header["metrics"] =
      "linear radiance on the GT foreground (alpha >= 0.5), both clipped per RGB channel to [0, clip_radiance] (the "
      "capture's linear white level; 0 = no clip), prediction (premultiplied) against GT x alpha: MAE, "
      "PSNR (peak 1), alpha MAE over the whole image (relight/metrics.h); SSIM per RGB channel, averaged, on the "
      "foreground's bounding box, linear values, L = 1 (Gaussian 11x11, sigma 1.5). Per light type: MAE/MSE/alpha "
      "pooled over foreground pixels, PSNR from the pooled MSE, SSIM the mean over images.";
  header["summary"] = summary;
  header["images"] = images;
  WriteJsonFile((fs::path(out_dir) / "eval.json").string(), "eval", 1, header);

  // eval.md: method x light type, "PSNR / MAE / SSIM", plus alpha MAE.
  std::string md = "# Evaluation against ground truth\n\n";
  const double clip = header.value("clip_radiance", 0.0);
  md += fmt::format("Truth: `{}`; {} views x {} lights. Cells: PSNR (dB) / MAE / SSIM, linear, on the GT "
                    "foreground (see eval.json \"metrics\"), {}.\n\n",
                    header.value("truth", std::string()), header.value("views", 0), header.value("lights", 0),
                    clip > 0 ? fmt::format("render and truth clipped at {:g} (eval.clip_radiance, the capture's "
                                           "linear white level)", clip)
                             : std::string("not clipped (eval.clip_radiance 0)"));
  if (header.contains("model_variant")) {
    md += fmt::format("Model input: `{}` ({}).\n\n", header.value("model_variant", std::string()),
                      header["model_input"].dump());
  }
  if (header.contains("skipped_reasons")) {
    for (const auto& [method, reason] : header["skipped_reasons"].items()) {
      md += "Skipped `" + method + "`: " + reason.get<std::string>() + ".\n\n";
    }
  }
  AppendMethodTable(&md, results, floors, methods, types, clip);
  for (const std::string& set : ViewSets(results)) {
    const std::vector<EvalImageResult> in_set = InViewSet(results, set), floors_in_set = InViewSet(floors, set);
    md += fmt::format("\n### {} views ({} images per method)\n\n", set == "interpolation" ? "Interpolation" : "Extrapolation",
                      Pool(in_set, methods.front(), "all").images);
    AppendMethodTable(&md, in_set, floors_in_set, methods, types, clip);
  }
  md += floors.empty() ? "\nTruth noise floor: not measured (the truth has no noise halves or twins).\n"
                       : "\nTruth noise floor: the score a perfect prediction of the converged image would get against "
                         "this truth (each eval image against one of the two independent halves it is the mean of, or "
                         "against a twin render, MSE halved). Scores within ~6 dB of it are limited by the truth's "
                         "noise, not by the method.\n";
  if (close_to_floor > 0) {
    md += fmt::format("\n\\* within {:g} dB of the truth's noise floor ({} pooled scores): such a score measures the "
                      "truth's noise as much as the method. Render the eval set with more samples per pixel "
                      "(relit-synth eval_samples_per_pixel, eval_environment_samples_per_pixel) before quoting it.\n",
                      kMinFloorMarginDb, close_to_floor);
    spdlog::warn("eval: {} pooled scores lie within {:g} dB of the truth's noise floor (eval.md, marked *): render "
                 "the eval set with more samples per pixel before quoting them",
                 close_to_floor, kMinFloorMarginDb);
  }
  md += "\n## Per image (PSNR dB / MAE / SSIM)\n\n| view | light |";
  for (const std::string& m : methods) md += " " + m + " |";
  md += "\n|---|---|";
  for (size_t i = 0; i < methods.size(); ++i) md += "---|";
  md += "\n";
  for (size_t i = 0; i < results.size(); i += methods.size()) {
    md += "| " + results[i].view + " | " + results[i].light + " |";
    for (size_t k = 0; k < methods.size() && i + k < results.size(); ++k) {
      const EvalImageResult& r = results[i + k];
      md += fmt::format(" {:.2f} / {:.4f} / {:.3f} |", r.metrics.psnr_db, r.metrics.mae, r.ssim);
    }
    md += "\n";
  }
  if (header.contains("light_unit")) {
    md += fmt::format("\nLight unit: GT strengths x {:.4g} (cue flash {:.4g} / true flash {:.4g} W/sr), exposure {:.4g}.\n",
                      header["light_unit"].value("factor", 0.0), header["light_unit"].value("cue_flash_intensity", 0.0),
                      header["light_unit"].value("true_flash_intensity_w_per_sr", 0.0),
                      header["light_unit"].value("exposure", 0.0));
  }
  AtomicWriteFile(fs::path(out_dir) / "eval.md", md);
}

}  // namespace relit::relight
