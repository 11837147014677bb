#include "calib/colmap_sfm.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <thread>

#include <sqlite3.h>
#include <spdlog/spdlog.h>

#include "calib/feature_matching.h"
#include "calib/pair_verification.h"
#include "core/error.h"
#include "core/run_record.h"
#include "core/shell.h"

namespace relit::calib {

namespace {

namespace fs = std::filesystem;

// Runs one COLMAP command with its output in work_dir/colmap_<step>.log.
double RunStep(const SfmRunOptions& o, const std::string& step, const std::string& arguments) {
  const std::string log = (fs::path(o.work_dir) / ("colmap_" + step + ".log")).string();
  const std::string command = "QT_QPA_PLATFORM=offscreen " + ShellQuote(o.colmap) + " " + step + " " +
                              arguments + " > " + ShellQuote(log) + " 2>&1";
  spdlog::info("sfm: colmap {}", step);
  spdlog::debug("sfm: {}", command);
  const auto start = std::chrono::steady_clock::now();
  const int status = std::system(command.c_str());
  const double seconds = SecondsSince(start);
  if (status != 0) {
    std::string tail;
    std::ifstream in(log);
    std::string line;
    while (std::getline(in, line)) {
      if (!line.empty()) tail = line;
    }
    Fail("COLMAP step '", step, "' failed (exit status ", status, "; is the colmap package "
         "installed? tools/install-deps): last line '", tail, "', full log ", log);
  }
  return seconds;
}

std::string Params(const Intrinsics& in) {
  // COLMAP OPENCV: fx, fy, cx, cy, k1, k2, p1, p2 with (0.5, 0.5) at the top-left pixel centre.
  std::ostringstream s;
  s.precision(17);
  s << in.fx << "," << in.fy << "," << in.cx + 0.5 << "," << in.cy + 0.5 << "," << in.distortion.k1 << ","
    << in.distortion.k2 << "," << in.distortion.p1 << "," << in.distortion.p2;
  return s.str();
}

int CountModelImages(const std::string& dir) {
  std::ifstream in(fs::path(dir) / "images.txt");
  int lines = 0;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#') ++lines;
  }
  return lines / 2;
}

// The board-seeded start: the known poses as a COLMAP text model with the
// database's image and camera ids. POINTS2D lines stay empty: COLMAP takes
// the keypoints from the database.
void WriteKnownPoseModel(const std::string& dir, const std::string& database,
                         const std::map<std::string, Intrinsics>& lenses, const std::vector<SfmImage>& images,
                         const std::map<std::string, Rigid3>& known_poses) {
  const std::map<std::string, ColmapIds> ids = ReadColmapImageIds(database);
  fs::create_directories(dir);
  std::map<std::string, long> camera_of_device;
  for (const SfmImage& image : images) {
    const auto it = ids.find(image.name);
    RELIT_REQUIRE(it != ids.end(), "COLMAP database ", database, " lacks image ", image.name,
                  ": feature extraction failed for it, see the colmap_feature_extractor.log beside it");
    camera_of_device[image.device] = it->second.camera_id;
  }
  std::ofstream cameras(fs::path(dir) / "cameras.txt");
  for (const auto& [device, camera_id] : camera_of_device) {
    const Intrinsics& lens = lenses.at(device);
    cameras << camera_id << " OPENCV " << lens.width << " " << lens.height << " ";
    std::string params = Params(lens);
    std::replace(params.begin(), params.end(), ',', ' ');
    cameras << params << "\n";
  }
  std::ofstream out(fs::path(dir) / "images.txt");
  out.precision(17);
  for (const SfmImage& image : images) {
    const auto pose = known_poses.find(image.name);
    if (pose == known_poses.end()) continue;
    const Eigen::Quaterniond& q = pose->second.rotation;
    const Eigen::Vector3d& t = pose->second.translation;
    const ColmapIds& id = ids.at(image.name);
    out << id.image_id << " " << q.w() << " " << q.x() << " " << q.y() << " " << q.z() << " " << t.x() << " "
        << t.y() << " " << t.z() << " " << id.camera_id << " " << image.name << "\n\n";
  }
  std::ofstream(fs::path(dir) / "points3D.txt");
}

// The board-seeded model in `out_dir`: points triangulated from the known
// poses (held fixed), the other images registered to those points, and the
// points triangulated again with every registered pose fixed.
void RunSeeded(const SfmRunOptions& o, const std::string& database, const std::vector<SfmImage>& images,
               const std::map<std::string, Intrinsics>& lenses, const std::string& out_dir,
               const std::string& mapper_flags, std::map<std::string, double>* timings_s) {
  const std::string known = (fs::path(o.work_dir) / "known_poses").string();
  fs::remove_all(known);
  WriteKnownPoseModel(known, database, lenses, images, o.known_poses);
  bool all_known = true;
  for (const SfmImage& image : images) all_known = all_known && o.known_poses.count(image.name);
  const std::string triangulated = all_known ? out_dir : (fs::path(o.work_dir) / "triangulated").string();
  fs::create_directories(triangulated);
  const std::string db = " --database_path " + ShellQuote(database) + " --random_seed 1";
  (*timings_s)["point_triangulator"] = RunStep(
      o, "point_triangulator",
      db + " --image_path " + ShellQuote(o.image_dir) + " --input_path " + ShellQuote(known) +
          " --output_path " + ShellQuote(triangulated) + mapper_flags);
  if (all_known) return;
  const std::string registered = (fs::path(o.work_dir) / "registered").string();
  fs::create_directories(registered);
  (*timings_s)["image_registrator"] = RunStep(
      o, "image_registrator",
      db + " --input_path " + ShellQuote(triangulated) + " --output_path " + ShellQuote(registered) + mapper_flags);
  // image_registrator only links the new frames to existing points: a second
  // triangulation (poses still fixed) extends the tracks through them.
  fs::create_directories(out_dir);
  (*timings_s)["point_triangulator"] += RunStep(
      o, "point_triangulator",
      db + " --image_path " + ShellQuote(o.image_dir) + " --input_path " + ShellQuote(registered) +
          " --output_path " + ShellQuote(out_dir) + mapper_flags);
}

}  // namespace

SfmModel ReadColmapTextModel(const std::string& dir) {
  SfmModel model;
  std::ifstream images(fs::path(dir) / "images.txt");
  RELIT_REQUIRE(images, "cannot read the COLMAP model ", dir, "/images.txt");
  std::map<long, std::string> names;
  std::map<long, std::vector<std::pair<Eigen::Vector2d, long>>> points2d;
  std::string line;
  while (std::getline(images, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream header(line);
    long id, camera;
    double qw, qx, qy, qz, tx, ty, tz;
    std::string name;
    RELIT_REQUIRE(static_cast<bool>(header >> id >> qw >> qx >> qy >> qz >> tx >> ty >> tz >> camera >> name),
                  dir, "/images.txt: cannot parse '", line, "'");
    names[id] = name;
    model.cam_from_model[name] = Rigid3(Eigen::Quaterniond(qw, qx, qy, qz), Eigen::Vector3d(tx, ty, tz));
    std::getline(images, line);
    std::istringstream pts(line);
    double x, y;
    long point;
    while (pts >> x >> y >> point) points2d[id].push_back({Eigen::Vector2d(x - 0.5, y - 0.5), point});
  }
  std::ifstream points(fs::path(dir) / "points3D.txt");
  RELIT_REQUIRE(points, "cannot read the COLMAP model ", dir, "/points3D.txt");
  while (std::getline(points, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    long id;
    double x, y, z, error;
    int r, g, b;
    RELIT_REQUIRE(static_cast<bool>(s >> id >> x >> y >> z >> r >> g >> b >> error), dir,
                  "/points3D.txt: cannot parse '", line, "'");
    std::vector<SfmTrackObservation> track;
    long image, index;
    while (s >> image >> index) {
      const auto it = points2d.find(image);
      RELIT_REQUIRE(it != points2d.end() && index >= 0 && index < static_cast<long>(it->second.size()),
                    dir, "/points3D.txt: point ", id, " refers to a missing observation");
      track.push_back({names.at(image), it->second[index].first});
    }
    model.points.emplace_back(x, y, z);
    model.tracks.push_back(track);
  }
  return model;
}

sqlite3* OpenColmapDatabase(const std::string& path, bool writable) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path.c_str(), &db, writable ? SQLITE_OPEN_READWRITE : SQLITE_OPEN_READONLY, nullptr) !=
      SQLITE_OK) {
    const std::string message = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    Fail("cannot open the COLMAP database ", path, writable ? " for writing: " : ": ", message);
  }
  return db;
}

// Runs one SQL query on a COLMAP database (read-only), calling `row` per row.
void QueryColmapDatabase(const std::string& path, const char* sql, const std::function<void(sqlite3_stmt*)>& row) {
  sqlite3* db = OpenColmapDatabase(path, false);
  sqlite3_stmt* statement = nullptr;
  if (sqlite3_prepare_v2(db, sql, -1, &statement, nullptr) != SQLITE_OK) {
    const std::string message = sqlite3_errmsg(db);
    sqlite3_close(db);
    Fail("COLMAP database ", path, ": ", message, " (in '", sql, "')");
  }
  while (sqlite3_step(statement) == SQLITE_ROW) row(statement);
  sqlite3_finalize(statement);
  sqlite3_close(db);
}

void ReadColmapDatabase(const std::string& path, std::map<std::string, int>* keypoints, int* verified_pairs) {
  QueryColmapDatabase(path, "SELECT images.name, keypoints.rows FROM images LEFT JOIN keypoints ON "
                      "images.image_id = keypoints.image_id",
                [&](sqlite3_stmt* s) {
                  (*keypoints)[reinterpret_cast<const char*>(sqlite3_column_text(s, 0))] = sqlite3_column_int(s, 1);
                });
  *verified_pairs = 0;
  QueryColmapDatabase(path, "SELECT COUNT(*) FROM two_view_geometries WHERE rows >= 15",
                [&](sqlite3_stmt* s) { *verified_pairs = sqlite3_column_int(s, 0); });
}

std::map<std::string, ColmapIds> ReadColmapImageIds(const std::string& path) {
  std::map<std::string, ColmapIds> ids;
  QueryColmapDatabase(path, "SELECT name, image_id, camera_id FROM images", [&](sqlite3_stmt* s) {
    ids[reinterpret_cast<const char*>(sqlite3_column_text(s, 0))] = {sqlite3_column_int64(s, 1),
                                                                     sqlite3_column_int64(s, 2)};
  });
  return ids;
}

namespace {

// COLMAP's own matching: its sequential matcher, then the extra pairs.
void MatchWithColmap(const std::vector<std::pair<std::string, std::string>>& pairs, const SfmRunOptions& o,
                     const std::string& common, int threads, SfmResult* result) {
  const std::string verification = " --SiftMatching.use_gpu 0 --SiftMatching.num_threads " +
                                   std::to_string(threads) + " --SiftMatching.max_num_trials " +
                                   std::to_string(o.ransac_trials);
  result->timings_s["sequential_matcher"] =
      RunStep(o, "sequential_matcher",
              common + verification + " --SequentialMatching.overlap " + std::to_string(o.sequential_overlap) +
                  " --SequentialMatching.loop_detection 0");
  if (pairs.empty()) return;
  const std::string list = (fs::path(o.work_dir) / "cross_pairs.txt").string();
  std::ofstream out(list);
  for (const auto& [a, b] : pairs) out << a << " " << b << "\n";
  out.close();
  result->timings_s["matches_importer"] = RunStep(
      o, "matches_importer", common + " --match_list_path " + ShellQuote(list) + " --match_type pairs" + verification);
}

// The same pairs (COLMAP's sequential ones and the extra ones) matched by
// OpenCV, then verified in process (pair_verification.h) or by COLMAP.
void MatchWithOpenCv(const std::vector<SfmImage>& images, const std::map<std::string, Intrinsics>& lenses,
                     const std::vector<std::pair<std::string, std::string>>& pairs, const SfmRunOptions& o,
                     const std::string& common, int threads, const std::string& database, SfmResult* result) {
  std::vector<std::string> names;
  std::map<std::string, Intrinsics> lens_of_image;
  for (const SfmImage& image : images) {
    names.push_back(image.name);
    lens_of_image[image.name] = lenses.at(image.device);
  }
  ImagePairs all = SequentialPairs(names, o.sequential_overlap);
  std::set<std::pair<std::string, std::string>> seen;
  for (const auto& [a, b] : all) seen.insert(std::minmax(a, b));
  for (const auto& pair : pairs) {
    if (seen.insert(std::minmax(pair.first, pair.second)).second) all.push_back(pair);
  }
  DescriptorMatchOptions match;
  match.threads = o.threads;
  spdlog::info("sfm: matching {} image pairs (OpenCV)", all.size());
  DescriptorMatchStats stats;
  const MatchedPairs matched = MatchDescriptors(database, all, match, &stats);
  spdlog::info("sfm: {} descriptor matches in {} pairs ({:.1f} s)", stats.matches, stats.pairs, stats.seconds);
  if (stats.pairs_without_descriptors > 0) {
    spdlog::warn("sfm: {} image pairs left out: COLMAP extracted no features from one of their images (see "
                 "colmap_feature_extractor.log)", stats.pairs_without_descriptors);
  }
  result->descriptor_matching_s = stats.seconds;
  if (o.verification == "opencv") {
    PairVerificationOptions verify;
    verify.max_trials = o.ransac_trials;
    verify.threads = o.threads;
    const PairVerificationStats v = VerifyAndStorePairs(database, matched, lens_of_image, verify);
    spdlog::info("sfm: {} of {} pairs verified, {} of {} matches inliers ({:.1f} s)", v.verified_pairs, v.pairs,
                 v.inliers, v.matches, v.seconds);
    result->pair_verification_s = v.seconds;
    return;
  }
  const std::string raw = (fs::path(o.work_dir) / "raw_matches.txt").string();
  WriteRawMatches(matched, raw);
  result->timings_s["matches_importer"] = RunStep(
      o, "matches_importer",
      common + " --match_list_path " + ShellQuote(raw) + " --match_type raw --SiftMatching.use_gpu 0" +
          " --SiftMatching.num_threads " + std::to_string(threads) + " --SiftMatching.max_num_trials " +
          std::to_string(o.ransac_trials));
}

// Feature extraction (one call per phone, each with its fixed lens),
// matching of the sequential and cross pairs, then the mapper or the seeded
// model, into `sparse`.
void RunColmapSteps(const std::vector<SfmImage>& images, const std::map<std::string, Intrinsics>& lenses,
                    const std::vector<std::pair<std::string, std::string>>& pairs, const SfmRunOptions& o,
                    const std::string& database, const std::string& sparse, SfmResult* result) {
  const int threads = o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const std::string common = " --database_path " + ShellQuote(database) + " --random_seed 1";
  for (const auto& [device, lens] : lenses) {
    const std::string list = (fs::path(o.work_dir) / ("images_" + device + ".txt")).string();
    std::ofstream out(list);
    int count = 0;
    for (const SfmImage& image : images) {
      if (image.device == device) {
        out << image.name << "\n";
        ++count;
      }
    }
    out.close();
    if (count == 0) continue;
    result->timings_s["feature_extractor"] += RunStep(
        o, "feature_extractor",
        common + " --image_path " + ShellQuote(o.image_dir) + " --image_list_path " + ShellQuote(list) +
            " --ImageReader.camera_model OPENCV --ImageReader.single_camera 1 --ImageReader.camera_params " +
            Params(lens) + " --SiftExtraction.use_gpu 0 --SiftExtraction.num_threads " + std::to_string(threads) +
            " --SiftExtraction.max_num_features " + std::to_string(o.max_features) +
            " --SiftExtraction.first_octave " + std::to_string(o.first_octave));
  }
  if (o.matcher == "opencv") {
    MatchWithOpenCv(images, lenses, pairs, o, common, threads, database, result);
  } else {
    MatchWithColmap(pairs, o, common, threads, result);
  }
  fs::remove_all(sparse);
  fs::create_directories(sparse);
  const std::string fixed_lens =
      " --Mapper.ba_refine_focal_length 0 --Mapper.ba_refine_principal_point 0 --Mapper.ba_refine_extra_params 0"
      " --Mapper.num_threads " + std::to_string(threads);
  if (o.known_poses.empty()) {
    const std::string growth = std::to_string(o.mapper_global_ba_growth);
    result->timings_s["mapper"] =
        RunStep(o, "mapper",
                common + " --image_path " + ShellQuote(o.image_dir) + " --output_path " + ShellQuote(sparse) +
                    fixed_lens + " --Mapper.ba_global_images_ratio " + growth +
                    " --Mapper.ba_global_points_ratio " + growth + " --Mapper.ba_global_max_refinements " +
                    std::to_string(o.mapper_global_ba_refinements));
  } else {
    RunSeeded(o, database, images, lenses, sparse + "/0", fixed_lens, &result->timings_s);
  }
  // Every model in text form (COLMAP may split the sequence into several).
  std::vector<fs::path> models;
  for (const auto& entry : fs::directory_iterator(sparse)) {
    if (entry.is_directory()) models.push_back(entry.path());
  }
  for (const fs::path& model : models) {
    const std::string text = model.string() + "_txt";
    fs::create_directories(text);
    result->timings_s["model_converter"] += RunStep(
        o, "model_converter",
        " --input_path " + ShellQuote(model.string()) + " --output_path " + ShellQuote(text) + " --output_type TXT");
  }
}

}  // namespace

SfmResult RunColmapSfm(const std::vector<SfmImage>& images, const std::map<std::string, Intrinsics>& lenses,
                       const std::vector<std::pair<std::string, std::string>>& pairs, const SfmRunOptions& o) {
  SfmResult result;
  result.images = static_cast<int>(images.size());
  fs::create_directories(o.work_dir);
  const std::string colmap_dir = o.reuse_dir.empty() ? o.work_dir : o.reuse_dir;
  const std::string database = (fs::path(colmap_dir) / "database.db").string();
  const std::string sparse = (fs::path(colmap_dir) / "sparse").string();
  if (o.reuse_dir.empty()) {
    fs::remove(database);
    RunColmapSteps(images, lenses, pairs, o, database, sparse, &result);
  } else {
    RELIT_REQUIRE(fs::exists(database) && fs::is_directory(sparse), "sfm.reuse_dir ", o.reuse_dir,
                  " holds no COLMAP run (database.db and sparse/ of a previous calib/sfm folder)");
    spdlog::info("sfm: reusing the COLMAP model of {} (no COLMAP step runs)", o.reuse_dir);
  }
  ReadColmapDatabase(database, &result.keypoints, &result.verified_pairs);
  // The largest model.
  std::string best_dir;
  int best = 0;
  for (const auto& entry : fs::directory_iterator(sparse)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_directory() || name.size() < 4 || name.substr(name.size() - 4) != "_txt") continue;
    const int count = CountModelImages(entry.path().string());
    result.model_sizes.push_back(count);
    if (count > best) {
      best = count;
      best_dir = entry.path().string();
    }
  }
  result.models = static_cast<int>(result.model_sizes.size());
  std::sort(result.model_sizes.rbegin(), result.model_sizes.rend());
  RELIT_REQUIRE(best >= o.min_registered, "COLMAP registered only ", best, " of ", images.size(),
                " images in its largest model (", result.models, " models, ", result.verified_pairs,
                " verified image pairs; need sfm.min_registered = ", o.min_registered,
                "). The frames may lack texture or overlap; see ", o.work_dir,
                "/colmap_mapper.log, or set sfm.enabled: false to use board poses only");
  result.model = ReadColmapTextModel(best_dir);
  for (const SfmImage& image : images) {
    if (result.model.cam_from_model.count(image.name)) {
      result.registered_by_device[image.device]++;
    } else {
      const int keypoints = result.keypoints.count(image.name) ? result.keypoints.at(image.name) : 0;
      result.unregistered[image.name] = keypoints < 100
                                            ? "few SIFT features (" + std::to_string(keypoints) + ")"
                                            : "not enough verified matches to the largest model";
    }
  }
  return result;
}

void WriteColmapTextModel(const std::string& dir, const std::map<std::string, Intrinsics>& lenses,
                          const std::vector<std::pair<std::string, std::string>>& image_devices,
                          const std::vector<Rigid3>& cam_from_world, const std::vector<Eigen::Vector3d>& points) {
  RELIT_CHECK(image_devices.size() == cam_from_world.size());
  fs::create_directories(dir);
  std::map<std::string, int> camera_ids;
  std::ofstream cameras(fs::path(dir) / "cameras.txt");
  cameras.precision(17);
  cameras << "# relit-calib: one camera per phone, COLMAP pixel convention (0.5, 0.5)\n"
             "# CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  for (const auto& [device, lens] : lenses) {
    const int id = static_cast<int>(camera_ids.size()) + 1;
    camera_ids[device] = id;
    const Distortion& d = lens.distortion;
    cameras << id << " FULL_OPENCV " << lens.width << " " << lens.height << " " << lens.fx << " " << lens.fy
            << " " << lens.cx + 0.5 << " " << lens.cy + 0.5 << " " << d.k1 << " " << d.k2 << " " << d.p1 << " "
            << d.p2 << " " << d.k3 << " 0 0 0\n";
  }
  std::ofstream out(fs::path(dir) / "images.txt");
  out.precision(17);
  out << "# relit-calib: poses in the world (board) frame, metres\n"
         "# IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n# POINTS2D[] (empty)\n";
  for (size_t i = 0; i < image_devices.size(); ++i) {
    const Eigen::Quaterniond& q = cam_from_world[i].rotation;
    const Eigen::Vector3d& t = cam_from_world[i].translation;
    out << i + 1 << " " << q.w() << " " << q.x() << " " << q.y() << " " << q.z() << " " << t.x() << " " << t.y()
        << " " << t.z() << " " << camera_ids.at(image_devices[i].second) << " " << image_devices[i].first << "\n\n";
  }
  std::ofstream pts(fs::path(dir) / "points3D.txt");
  pts.precision(10);
  pts << "# POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] (tracks not exported)\n";
  for (size_t i = 0; i < points.size(); ++i) {
    pts << i + 1 << " " << points[i].x() << " " << points[i].y() << " " << points[i].z() << " 128 128 128 0\n";
  }
}

}  // namespace relit::calib
