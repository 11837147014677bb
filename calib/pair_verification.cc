#include "calib/pair_verification.h"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>

#include <opencv2/calib3d.hpp>
#include <sqlite3.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "calib/colmap_sfm.h"
#include "core/error.h"
#include "core/run_record.h"

namespace relit::calib {

namespace {

// COLMAP's pair id: the smaller image id first (scripts/python/database.py).
constexpr int64_t kMaxImageId = 2147483647;

// COLMAP's TwoViewGeometry::ConfigurationType values.
constexpr int kDegenerate = 1;
constexpr int kCalibrated = 2;

// Keypoint positions per image name, in relit's pixel convention (COLMAP
// stores (0.5, 0.5) at the top-left pixel centre).
std::map<std::string, std::vector<Eigen::Vector2d>> ReadKeypoints(const std::string& database) {
  std::map<std::string, std::vector<Eigen::Vector2d>> keypoints;
  QueryColmapDatabase(database, "SELECT images.name, keypoints.rows, keypoints.cols, keypoints.data FROM images "
                      "JOIN keypoints ON images.image_id = keypoints.image_id",
                      [&](sqlite3_stmt* s) {
    const std::string name = reinterpret_cast<const char*>(sqlite3_column_text(s, 0));
    const int rows = sqlite3_column_int(s, 1), cols = sqlite3_column_int(s, 2);
    RELIT_REQUIRE(cols >= 2 && sqlite3_column_bytes(s, 3) == rows * cols * 4, "COLMAP database ", database,
                  ": unexpected keypoint block of ", name, " (", rows, " x ", cols,
                  "); was it written by Debian's colmap 3.8?");
    std::vector<float> data(static_cast<size_t>(rows) * cols);
    if (rows > 0) std::memcpy(data.data(), sqlite3_column_blob(s, 3), data.size() * sizeof(float));
    std::vector<Eigen::Vector2d>& points = keypoints[name];
    for (int r = 0; r < rows; ++r) points.emplace_back(data[r * cols] - 0.5, data[r * cols + 1] - 0.5);
  });
  return keypoints;
}

// Undistorted normalised coordinates (x / z, y / z of each pixel's ray).
std::vector<Eigen::Vector2d> Normalized(const std::vector<Eigen::Vector2d>& pixels, const Intrinsics& lens) {
  const Camera camera(lens, Rigid3());
  std::vector<Eigen::Vector2d> out;
  out.reserve(pixels.size());
  for (const Eigen::Vector2d& p : pixels) out.push_back(camera.PixelToCameraRay(p).hnormalized());
  return out;
}

// One pair's result: inlier indices and the essential matrix (row-major).
struct PairGeometry {
  std::vector<int> inliers;
  cv::Matx33d essential = cv::Matx33d::eye();
};

PairGeometry Verify(const std::vector<Eigen::Vector2d>& a, const std::vector<Eigen::Vector2d>& b,
                    const std::vector<std::pair<int, int>>& matches, double max_error,
                    const PairVerificationOptions& o) {
  PairGeometry out;
  // Five points per sample; fewer matches than the inlier minimum cannot pass.
  if (static_cast<int>(matches.size()) < std::max(5, o.min_inliers)) return out;
  std::vector<cv::Point2d> pa, pb;
  for (const auto& [i, j] : matches) {
    pa.emplace_back(a[i].x(), a[i].y());
    pb.emplace_back(b[j].x(), b[j].y());
  }
  cv::Mat mask, e;
  try {
    e = cv::findEssentialMat(pa, pb, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, o.confidence, max_error, o.max_trials,
                             mask);
  } catch (const cv::Exception&) {
    return out;  // a degenerate pair (e.g. all matches at one position): unverified, as COLMAP leaves it
  }
  // Degenerate samples can yield several stacked solutions or none.
  if (e.rows != 3 || e.cols != 3 || mask.empty()) return out;
  for (int k = 0; k < mask.rows; ++k) {
    if (mask.at<uint8_t>(k)) out.inliers.push_back(k);
  }
  if (static_cast<int>(out.inliers.size()) < o.min_inliers) {
    out.inliers.clear();
    return out;
  }
  out.essential = cv::Matx33d(e.ptr<double>());
  return out;
}

// COLMAP's pixel convention for its camera matrix.
cv::Matx33d ColmapCameraMatrix(const Intrinsics& lens) {
  return {lens.fx, 0, lens.cx + 0.5, 0, lens.fy, lens.cy + 0.5, 0, 0, 1};
}

class Statement {
 public:
  Statement(sqlite3* db, const char* sql) {
    RELIT_REQUIRE(sqlite3_prepare_v2(db, sql, -1, &statement_, nullptr) == SQLITE_OK, "COLMAP database: ",
                  sqlite3_errmsg(db), " (in '", sql, "')");
  }
  ~Statement() { sqlite3_finalize(statement_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  sqlite3_stmt* get() { return statement_; }
  void Run(sqlite3* db) {
    RELIT_REQUIRE(sqlite3_step(statement_) == SQLITE_DONE, "cannot write the COLMAP database: ",
                  sqlite3_errmsg(db));
    sqlite3_reset(statement_);
  }

 private:
  sqlite3_stmt* statement_ = nullptr;
};

void BindBlob(sqlite3_stmt* s, int column, const void* data, size_t bytes) {
  sqlite3_bind_blob(s, column, data, static_cast<int>(bytes), SQLITE_TRANSIENT);
}

void Exec(sqlite3* db, const char* sql) {
  char* message = nullptr;
  if (sqlite3_exec(db, sql, nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string text = message ? message : "unknown error";
    sqlite3_free(message);
    Fail("cannot write the COLMAP database: ", text, " (in '", sql, "')");
  }
}

// Writes every pair in one transaction: a failure leaves the database as
// COLMAP's feature extraction left it.
void StorePairs(const std::string& database, const MatchedPairs& matched, const std::vector<PairGeometry>& geometry,
                const std::map<std::string, Intrinsics>& lens_of_image) {
  const std::map<std::string, ColmapIds> ids = ReadColmapImageIds(database);
  sqlite3* db = OpenColmapDatabase(database, true);
  try {
    Exec(db, "BEGIN TRANSACTION");
    Statement matches(db, "INSERT OR REPLACE INTO matches (pair_id, rows, cols, data) VALUES (?, ?, 2, ?)");
    Statement geometries(db, "INSERT OR REPLACE INTO two_view_geometries (pair_id, rows, cols, data, config, F, "
                             "E, H, qvec, tvec) VALUES (?, ?, 2, ?, ?, ?, ?, ?, ?, ?)");
    const cv::Matx33d identity = cv::Matx33d::eye();
    const double qvec[4] = {1, 0, 0, 0}, tvec[3] = {0, 0, 0};  // relative pose not computed (COLMAP's default)
    for (size_t p = 0; p < matched.pairs.size(); ++p) {
      const auto& [first, second] = matched.pairs[p];
      int64_t id1 = ids.at(first).image_id, id2 = ids.at(second).image_id;
      const bool swap = id1 > id2;
      if (swap) std::swap(id1, id2);
      const int64_t pair_id = kMaxImageId * id1 + id2;
      std::vector<uint32_t> all, inliers;
      for (const auto& [i, j] : matched.matches[p]) {
        all.push_back(static_cast<uint32_t>(swap ? j : i));
        all.push_back(static_cast<uint32_t>(swap ? i : j));
      }
      for (int k : geometry[p].inliers) inliers.insert(inliers.end(), {all[2 * k], all[2 * k + 1]});
      sqlite3_bind_int64(matches.get(), 1, pair_id);
      sqlite3_bind_int64(matches.get(), 2, static_cast<int64_t>(all.size() / 2));
      BindBlob(matches.get(), 3, all.data(), all.size() * sizeof(uint32_t));
      matches.Run(db);
      // E maps the first image's rays to the second's; COLMAP's pair order may be the reverse.
      const cv::Matx33d e = swap ? geometry[p].essential.t() : geometry[p].essential;
      const cv::Matx33d k1 = ColmapCameraMatrix(lens_of_image.at(swap ? second : first));
      const cv::Matx33d k2 = ColmapCameraMatrix(lens_of_image.at(swap ? first : second));
      const cv::Matx33d f = k2.inv().t() * e * k1.inv();
      const bool verified = !inliers.empty();
      sqlite3_stmt* g = geometries.get();
      sqlite3_bind_int64(g, 1, pair_id);
      sqlite3_bind_int64(g, 2, static_cast<int64_t>(inliers.size() / 2));
      BindBlob(g, 3, inliers.data(), inliers.size() * sizeof(uint32_t));
      sqlite3_bind_int(g, 4, verified ? kCalibrated : kDegenerate);
      BindBlob(g, 5, verified ? f.val : identity.val, sizeof(f.val));
      BindBlob(g, 6, verified ? e.val : identity.val, sizeof(e.val));
      BindBlob(g, 7, identity.val, sizeof(identity.val));  // no homography estimated
      BindBlob(g, 8, qvec, sizeof(qvec));
      BindBlob(g, 9, tvec, sizeof(tvec));
      geometries.Run(db);
    }
    Exec(db, "COMMIT");
  } catch (...) {
    sqlite3_exec(db, "ROLLBACK", nullptr, nullptr, nullptr);
    sqlite3_close(db);
    throw;
  }
  sqlite3_close(db);
}

}  // namespace

std::vector<int> EssentialInliers(const std::vector<Eigen::Vector2d>& normalized_a,
                                  const std::vector<Eigen::Vector2d>& normalized_b,
                                  const std::vector<std::pair<int, int>>& matches, double max_error,
                                  const PairVerificationOptions& options) {
  return Verify(normalized_a, normalized_b, matches, max_error, options).inliers;
}

PairVerificationStats VerifyAndStorePairs(const std::string& database, const MatchedPairs& matched,
                                          const std::map<std::string, Intrinsics>& lens_of_image,
                                          const PairVerificationOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const auto keypoints = ReadKeypoints(database);
  auto lens = [&](const std::string& name) -> const Intrinsics& {
    const auto it = lens_of_image.find(name);
    RELIT_REQUIRE(it != lens_of_image.end(), "pair verification: no lens for image ", name);
    return it->second;
  };
  std::map<std::string, std::vector<Eigen::Vector2d>> normalized;
  for (const auto& pair : matched.pairs) {
    for (const std::string& name : {pair.first, pair.second}) {
      if (normalized.count(name)) continue;
      const auto it = keypoints.find(name);
      RELIT_REQUIRE(it != keypoints.end(), "COLMAP database ", database, " has descriptors but no keypoints for ",
                    name, ": delete it and rerun calib");
      normalized[name] = Normalized(it->second, lens(name));
    }
  }
  PairVerificationStats stats;
  stats.pairs = static_cast<int>(matched.pairs.size());
  std::vector<PairGeometry> geometry(matched.pairs.size());
  auto run = [&] {
    tbb::parallel_for(size_t(0), matched.pairs.size(), [&](size_t p) {
      const auto& [first, second] = matched.pairs[p];
      // COLMAP's threshold: the pixel error at the mean focal length of the two lenses.
      const Intrinsics& a = lens(first);
      const Intrinsics& b = lens(second);
      const double focal = (a.fx + a.fy + b.fx + b.fy) / 4;
      geometry[p] = Verify(normalized.at(first), normalized.at(second), matched.matches[p],
                           options.max_error_px / focal, options);
    });
  };
  if (options.threads > 0) {
    tbb::task_arena(options.threads).execute(run);
  } else {
    run();
  }
  for (size_t p = 0; p < matched.pairs.size(); ++p) {
    stats.matches += static_cast<long>(matched.matches[p].size());
    stats.inliers += static_cast<long>(geometry[p].inliers.size());
    if (!geometry[p].inliers.empty()) ++stats.verified_pairs;
  }
  StorePairs(database, matched, geometry, lens_of_image);
  stats.seconds = SecondsSince(start);
  return stats;
}

}  // namespace relit::calib
