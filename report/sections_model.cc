// Reconstruction, training, rendering and evaluation sections.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>

#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/json_file.h"
#include "core/workspace.h"
#include "report/sections.h"
#include "report/svg_plot.h"

namespace relit::report {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Stage JSON paths are relative to the workspace root; accept paths relative
// to the file's own folder too.
fs::path Resolve(const ReportContext& context, const std::string& folder, const std::string& path) {
  if (fs::path(path).is_absolute()) return path;
  if (fs::exists(context.Input(path))) return context.Input(path);
  return context.Input(folder) / path;
}

std::vector<fs::path> SortedFiles(const fs::path& dir, const std::string& extension) {
  std::vector<fs::path> files;
  if (!fs::is_directory(dir)) return files;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.is_regular_file() && entry.path().extension() == extension) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// One table per top-level array of objects (rows = entries, columns = their
// scalar fields), for result files whose exact layout the report does not fix.
std::string ArrayTables(const json& object) {
  std::string html;
  for (auto it = object.begin(); it != object.end(); ++it) {
    if (!it.value().is_array() || it.value().empty() || !it.value()[0].is_object()) continue;
    std::vector<std::string> columns;
    std::set<std::string> seen;
    for (const json& row : it.value()) {
      for (auto f = row.begin(); f != row.end(); ++f) {
        if (!f.value().is_structured() && seen.insert(f.key()).second && columns.size() < 14) columns.push_back(f.key());
      }
    }
    std::vector<std::vector<std::string>> rows;
    for (const json& row : it.value()) {
      std::vector<std::string> cells;
      for (const std::string& c : columns) cells.push_back(row.contains(c) ? JsonScalarText(row[c]) : "");
      rows.push_back(cells);
    }
    html += "<h4>" + Html(it.key()) + "</h4>\n" + Table(columns, rows);
  }
  return html;
}

struct TrainingLog {
  std::vector<double> step, loss, rgb_loss, mask_loss;
  std::vector<double> val_step, val_psnr_db, val_mae;
};

TrainingLog ReadTrainingLog(const fs::path& path) {
  TrainingLog log;
  std::ifstream in(path);
  RELIT_REQUIRE(in.good(), "cannot open ", path.string());
  std::string line;
  int number = 0;
  auto num = [](const json& j, const char* key) {
    return j.contains(key) && j[key].is_number() ? j[key].get<double>() : NAN;
  };
  while (std::getline(in, line)) {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    json j;
    try {
      j = json::parse(line);
    } catch (const json::parse_error& e) {
      Fail(path.string(), ":", number, ": not a JSON line (", e.what(), ")");
    }
    RELIT_REQUIRE(j.is_object() && j.contains("step") && j["step"].is_number(), path.string(), ":", number,
                  ": a log line needs a numeric \"step\"");
    if (j.contains("val_psnr_db") || j.contains("val_mae")) {
      log.val_step.push_back(j["step"].get<double>());
      log.val_psnr_db.push_back(num(j, "val_psnr_db"));
      log.val_mae.push_back(num(j, "val_mae"));
    }
    if (j.contains("loss")) {
      log.step.push_back(j["step"].get<double>());
      log.loss.push_back(num(j, "loss"));
      log.rgb_loss.push_back(num(j, "rgb_loss"));
      log.mask_loss.push_back(num(j, "mask_loss"));
    }
  }
  return log;
}

double LastFinite(const std::vector<double>& v) {
  for (auto it = v.rbegin(); it != v.rend(); ++it) {
    if (std::isfinite(*it)) return *it;
  }
  return NAN;
}

}  // namespace

void ReadObjectCentre(ReportContext& context) {
  if (!context.Has("reconstruct/proxy.json")) return;
  try {
    const ProxyFile proxy = ReadProxyFile(context.Input("reconstruct/proxy.json").string());
    context.object_centre_m = proxy.object_centre_m;
    context.object_radius_m = proxy.object_radius_m;
    context.object_centre_source = "object centre from proxy.json";
  } catch (const Error& e) {
    spdlog::warn("report: {} (using the board origin as object centre)", e.what());
  }
}

Section ReconstructSection(ReportContext& context) {
  Section section{"reconstruct", "Proxy mesh, UV atlas, trimaps and mattes", ""};
  if (!context.Has("reconstruct/proxy.json")) {
    return NotRunSection(section, "W/reconstruct/proxy.json", "Run relit-reconstruct --workspace W --mesh scan.obj.");
  }
  std::string& html = section.html;
  const ProxyFile proxy = ReadProxyFile(context.Input("reconstruct/proxy.json").string());
  html += Paragraph("Object centre " + Fixed(proxy.object_centre_m.x(), 3) + ", " + Fixed(proxy.object_centre_m.y(), 3) +
                    ", " + Fixed(proxy.object_centre_m.z(), 3) + " m, radius " + Fixed(proxy.object_radius_m, 3) +
                    " m; atlas " + std::to_string(proxy.atlas_resolution_px) + " px; " +
                    std::to_string(proxy.mattes.size()) + " mattes.");
  if (context.Has("reconstruct/reconstruct_report.json")) {
    const json report = ReadJsonFile(context.Input("reconstruct/reconstruct_report.json").string(),
                                     "reconstruct_report", 1);
    html += "<details><summary>Mesh and atlas figures (reconstruct_report.json)</summary>" +
            ScalarTable(report.value("mesh", json::object()), 1) + ScalarTable(report.value("atlas", json::object()), 1) +
            "</details>\n";
  }
  std::vector<std::string> figures;
  const fs::path mesh = Resolve(context, "reconstruct", proxy.mesh);
  const std::vector<std::string> previews =
      context.MeshPreviews(mesh, proxy.object_centre_m, proxy.object_radius_m, "proxy_preview");
  for (size_t k = 0; k < previews.size(); ++k) {
    figures.push_back(Figure(previews[k], "proxy mesh, view " + std::to_string(k + 1) + " (headlight)"));
  }
  html += "<h3>Proxy mesh</h3>\n" + FigureRow(figures);
  if (context.Has("reconstruct/atlas_preview.png")) {
    html += "<h3>UV atlas</h3>\n" +
            FigureRow({Figure(context.Thumbnail(context.Input("reconstruct/atlas_preview.png"), "atlas_preview", 420),
                              "charts in colour with their triangle edges")});
  } else {
    html += Paragraph("No atlas preview (atlas.write_preview: false).");
  }
  // Sample frames with their trimap and matte.
  std::vector<const ViewMatte*> mattes;
  for (const ViewMatte& m : proxy.mattes) {
    if (!m.matte.empty() && !m.trimap.empty()) mattes.push_back(&m);
  }
  std::unique_ptr<CamerasFile> cameras;
  if (context.Has("calib/cameras.json")) {
    cameras = std::make_unique<CamerasFile>(ReadCamerasFile(context.Input("calib/cameras.json").string()));
  }
  html += "<h3>Sample trimaps and mattes</h3>\n";
  for (const size_t i : EvenlySpread(mattes.size(), context.options().sample_frames)) {
    const ViewMatte& m = *mattes[i];
    std::string stem = m.view_frame;
    std::replace(stem.begin(), stem.end(), '/', '_');
    std::vector<std::string> row;
    const CalibratedFrame* frame = cameras ? cameras->Find(m.view_frame) : nullptr;
    if (frame != nullptr && !frame->image_8bit.empty()) {
      row.push_back(Figure(context.Thumbnail(Resolve(context, "calib", frame->image_8bit), stem + "_image"),
                           m.view_frame + " (undistorted)"));
    }
    row.push_back(Figure(context.Thumbnail(Resolve(context, "reconstruct", m.trimap), stem + "_trimap"),
                         "trimap: black background, grey unknown, white object"));
    row.push_back(Figure(context.Thumbnail(Resolve(context, "reconstruct", m.matte), stem + "_matte"), "matte"));
    html += FigureRow(row);
  }
  if (mattes.empty()) html += Paragraph("No frame has a matte.");
  return section;
}

Section TrainingSection(ReportContext& context) {
  Section section{"training", "Training and validation per partition", ""};
  const fs::path dir = context.Input("relight/partitions");
  if (!fs::is_directory(dir)) {
    return NotRunSection(section, "W/relight/partitions",
                         "Run relit-relight plan, then relit-relight train --partition K.");
  }
  std::string& html = section.html;
  std::vector<fs::path> partitions;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_directory() && !name.empty() && std::all_of(name.begin(), name.end(), ::isdigit)) {
      partitions.push_back(entry.path());
    }
  }
  std::sort(partitions.begin(), partitions.end());
  std::vector<std::vector<std::string>> rows;
  std::vector<PlotSeries> all_psnr;
  std::vector<std::string> figures;
  for (const fs::path& p : partitions) {
    const std::string k = p.filename().string();
    std::string status = "no log yet";
    json train;
    if (fs::exists(p / "train.json")) {
      train = ReadAnyJson(p / "train.json");
      status = train.contains("skipped") ? "skipped: " + JsonScalarText(train["skipped"]) : "finished";
    }
    if (!fs::exists(p / "log.jsonl")) {
      rows.push_back({k, status, "", "", "", ""});
      continue;
    }
    if (status == "no log yet") status = "running or stopped";
    const TrainingLog log = ReadTrainingLog(p / "log.jsonl");
    double best_psnr = NAN;
    for (const double v : log.val_psnr_db) {
      if (std::isfinite(v)) best_psnr = std::isfinite(best_psnr) ? std::max(best_psnr, v) : v;
    }
    rows.push_back({k, status, log.step.empty() ? "0" : JsonScalarText(json(log.step.back())),
                    Fixed(LastFinite(log.loss), 4), Fixed(best_psnr, 2), Fixed(LastFinite(log.val_psnr_db), 2)});
    PlotOptions loss{"partition " + k + ": training loss", "step", "loss", 380, 240};
    loss.log_y = true;
    PlotOptions psnr = loss;
    psnr.title = "partition " + k + ": validation PSNR";
    psnr.y_label = "PSNR (dB)";
    psnr.log_y = false;
    std::vector<PlotSeries> losses = {{"loss", log.step, log.loss}, {"rgb", log.step, log.rgb_loss}};
    // A model without a mask network logs a mask loss of 0: nothing to draw on a log scale.
    if (std::any_of(log.mask_loss.begin(), log.mask_loss.end(), [](double v) { return v > 0; })) {
      losses.push_back({"mask", log.step, log.mask_loss});
    }
    figures.push_back(Figure(context.WriteAsset("training_" + k + "_loss.svg", PlotSvg(loss, losses)),
                             "partition " + k + ": loss per step (log scale)"));
    figures.push_back(Figure(context.WriteAsset("training_" + k + "_psnr.svg",
                                                PlotSvg(psnr, {{"validation", log.val_step, log.val_psnr_db, "", true,
                                                                true}})),
                             "partition " + k + ": validation PSNR"));
    all_psnr.push_back({"partition " + k, log.val_step, log.val_psnr_db});
  }
  if (partitions.empty()) {
    html += NotRunYet("any W/relight/partitions/KK", "Run relit-relight train --partition K.");
    return section;
  }
  html += Table({"partition", "status", "steps", "last loss", "best validation PSNR (dB)", "last validation PSNR (dB)"},
                rows);
  if (all_psnr.size() > 1) {
    const PlotOptions overview{"Validation PSNR of every partition", "step", "PSNR (dB)"};
    html += FigureRow({Figure(context.WriteAsset("training_psnr_all.svg", PlotSvg(overview, all_psnr)),
                              "all partitions")});
  }
  html += FigureRow(figures);
  return section;
}

Section RenderSection(ReportContext& context) {
  Section section{"render", "Relit turntables", ""};
  const fs::path dir = context.Input("relight/render");
  if (!fs::is_directory(dir)) {
    return NotRunSection(section, "W/relight/render", "Run relit-relight render after training.");
  }
  std::string& html = section.html;
  const std::vector<std::pair<std::string, std::string>> turntables = {
      {"turntable_point", "under a point light"}, {"turntable_env", "under an environment map"}};
  for (const auto& [name, what] : turntables) {
    html += "<h3>Turntable " + Html(what) + "</h3>\n";
    const std::vector<fs::path> frames = SortedFiles(dir / name, ".png");
    if (frames.empty()) {
      html += NotRunYet("W/relight/render/" + name + "/*.png", "Rerun relit-relight render.");
      continue;
    }
    std::vector<std::string> strip;
    for (const size_t i : EvenlySpread(frames.size(), context.options().strip_frames)) {
      const std::string stem = frames[i].stem().string();
      strip.push_back(Figure(context.Thumbnail(frames[i], name + "_" + stem, std::max(64, context.options().thumbnail_width_px * 2 / 3)),
                             "frame " + stem));
    }
    html += FigureRow(strip);
    if (fs::exists(dir / (name + ".mp4"))) {
      html += "<p><a href=\"../relight/render/" + Html(name) + ".mp4\">" + Html(name) + ".mp4</a> (" +
              std::to_string(frames.size()) + " frames; in the workspace, not copied into the report)</p>\n";
    } else {
      html += Paragraph(std::to_string(frames.size()) + " frames; no " + name + ".mp4.");
    }
  }
  if (fs::exists(dir / "render.json")) {
    html += "<details><summary>render.json</summary>" + ScalarTable(ReadAnyJson(dir / "render.json"), 2) +
            "</details>\n";
  }
  return section;
}

namespace {

// eval.json of `relit-relight eval` (relit.eval/1): the method x light type
// table of eval.md as HTML, and GT / render / error map thumbnails of the
// first view under one light of each type.
std::string EvalTables(ReportContext& context, const fs::path& dir, const json& eval) {
  std::string html;
  const std::vector<std::string> methods = eval.at("methods").get<std::vector<std::string>>();
  std::vector<std::string> types = eval.at("light_types").get<std::vector<std::string>>();
  types.push_back("all");
  auto number = [](const json& row, const char* key, int decimals) {
    return row.contains(key) && row[key].is_number() ? Fixed(row[key].get<double>(), decimals) : std::string("–");
  };
  std::vector<std::string> header = {"method"};
  for (const std::string& t : types) header.push_back(t);
  header.push_back("alpha MAE");
  // eval writes each row's margin to the truth's noise floor and the margin below which it marks a score.
  const json floor_info = eval.value("truth_noise_floor", json::object());
  const double min_margin_db = floor_info.value("min_margin_db", 0.0);
  std::vector<std::vector<std::string>> rows;
  for (const std::string& method : methods) {
    std::vector<std::string> cells(types.size() + 2, "–");
    cells[0] = method;
    for (const json& row : eval.at("summary")) {
      if (row.value("method", "") != method) continue;
      const auto it = std::find(types.begin(), types.end(), row.value("light_type", ""));
      if (it == types.end()) continue;
      const bool near_floor = row.contains("truth_floor_margin_db") && row["truth_floor_margin_db"].is_number() &&
                              row["truth_floor_margin_db"].get<double>() < min_margin_db;
      cells[1 + (it - types.begin())] = number(row, "psnr_db", 2) + " / " + number(row, "mae", 4) + " / " +
                                        number(row, "ssim", 3) + (near_floor ? " *" : "");
      if (*it == "all") cells.back() = number(row, "alpha_mae", 4);
    }
    rows.push_back(cells);
  }
  const json floor = floor_info.value("per_light_type", json::object());
  if (!floor.empty()) {
    std::vector<std::string> cells(types.size() + 2, "–");
    cells[0] = "truth noise floor";
    for (size_t i = 0; i < types.size(); ++i) {
      if (floor.contains(types[i])) cells[1 + i] = number(floor[types[i]], "psnr_db", 2) + " / " + number(floor[types[i]], "mae", 4);
    }
    cells.back() = "";
    rows.push_back(cells);
  }
  const double clip = eval.value("clip_radiance", 0.0);
  html += Paragraph("Cells: PSNR (dB) / MAE / SSIM, linear radiance on the ground-truth foreground, " +
                    std::to_string(eval.value("views", 0)) + " held-out views x " +
                    std::to_string(eval.value("lights", 0)) + " lights; " +
                    (clip > 0 ? "render and truth clipped at " + Fixed(clip, 3) + " (the capture's white level)"
                              : std::string("not clipped")) + ".");
  html += Table(header, rows);
  if (!floor.empty()) {
    const int near = floor_info.value("scores_within_min_margin", 0);
    html += Paragraph("Truth noise floor: the score a perfect prediction of the converged image gets against this "
                      "truth; scores within " + Fixed(min_margin_db, 0) +
                      " dB of it measure the truth's noise as much as the method" +
                      (near > 0 ? std::string(" (marked *: render the eval set with more samples per pixel before "
                                              "quoting them).")
                                : std::string(".")));
  }
  if (eval.contains("light_unit")) {
    html += Paragraph("Light unit: ground-truth strengths x " + Fixed(eval["light_unit"].value("factor", 0.0), 4) +
                      " (cue flash / true flash); exposure " + Fixed(eval["light_unit"].value("exposure", 1.0), 3) + ".");
  }
  // Error maps: the first view under the first light of each type.
  const json& images = eval.at("images");
  const std::string first_view = images.empty() ? "" : images[0].value("view", "");
  std::map<std::string, std::string> light_of_type;
  for (const json& image : images) {
    if (image.value("view", "") == first_view) light_of_type.emplace(image.value("light_type", ""), image.value("light", ""));
  }
  const double scale = eval.value("options", json::object()).value("error_map_scale", 5.0);
  std::vector<std::string> figures;
  std::set<std::string> shown_references;
  for (const json& image : images) {
    const std::string light = image.value("light", ""), method = image.value("method", "");
    if (image.value("view", "") != first_view || light_of_type[image.value("light_type", "")] != light ||
        !image.contains("error_png")) {
      continue;
    }
    const std::string stem = "eval_" + first_view + "_" + light;
    if (shown_references.insert(light).second) {
      figures.push_back(Figure(context.Thumbnail(dir / image["reference_png"].get<std::string>(), stem + "_gt"),
                               first_view + ", " + light + ": ground truth"));
    }
    figures.push_back(Figure(context.Thumbnail(dir / image["render_png"].get<std::string>(), stem + "_" + method),
                             method));
    figures.push_back(Figure(context.Thumbnail(dir / image["error_png"].get<std::string>(), stem + "_" + method + "_error"),
                             method + ": |error| x " + Fixed(scale, 0)));
  }
  if (!figures.empty()) html += FigureRow(figures);
  // Every eval image zoomed on the object: truth | each method.
  if (eval.contains("zoom_pngs") && !eval["zoom_pngs"].empty()) {
    std::string zooms;
    for (const json& zoom : eval["zoom_pngs"]) {
      const std::string view = zoom.value("view", ""), light = zoom.value("light", "");
      std::string columns;
      for (const json& c : zoom.value("columns", json::array())) columns += (columns.empty() ? "" : " | ") + c.get<std::string>();
      zooms += Figure(context.Thumbnail(dir / zoom.value("png", ""), "eval_zoom_" + view + "_" + light),
                      view + " (" + zoom.value("view_set", "") + "), " + light + ": " + columns);
    }
    html += "<details open><summary>Every eval image, zoomed on the object (truth | methods)</summary>" + zooms +
            "</details>\n";
  }
  std::vector<std::vector<std::string>> image_rows;
  for (const json& image : eval.at("images")) {
    image_rows.push_back({image.value("view", ""), image.value("light", ""), image.value("method", ""),
                          number(image, "psnr_db", 2), number(image, "mae", 4), number(image, "ssim", 3),
                          number(image, "alpha_mae", 4)});
  }
  html += "<details><summary>Per image</summary>" +
          Table({"view", "light", "method", "PSNR (dB)", "MAE", "SSIM", "alpha MAE"}, image_rows) + "</details>\n";
  return html;
}

}  // namespace

Section EvalSection(ReportContext& context) {
  Section section{"eval", "Evaluation against ground truth", ""};
  const fs::path dir = context.Input("relight/eval");
  if (!fs::exists(dir / "eval.json") && !fs::exists(dir / "eval.md")) {
    return NotRunSection(section, "W/relight/eval/eval.json",
                         "Run relit-relight eval --truth CAPTURE/truth.json on a capture with ground truth "
                         "(relit-synth).");
  }
  std::string& html = section.html;
  if (fs::exists(dir / "eval.json")) {
    const json eval = ReadAnyJson(dir / "eval.json");
    if (eval.value("schema", "") == SchemaString("eval", 1)) {
      html += EvalTables(context, dir, eval);
    } else {  // another layout: show what it holds
      html += ArrayTables(eval);
      html += "<details><summary>All scalar fields of eval.json</summary>" + ScalarTable(eval, 3) + "</details>\n";
    }
  }
  if (fs::exists(dir / "eval.md")) {
    std::ifstream in(dir / "eval.md");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    html += "<details><summary>eval.md</summary><pre>" + Html(text) + "</pre></details>\n";
  }
  return section;
}

}  // namespace relit::report
