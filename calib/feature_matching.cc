#include "calib/feature_matching.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <set>

#include <opencv2/core.hpp>
#include <sqlite3.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "calib/colmap_sfm.h"
#include "core/error.h"
#include "core/run_record.h"

namespace relit::calib {

ImagePairs SequentialPairs(std::vector<std::string> names, int overlap) {
  std::sort(names.begin(), names.end());
  ImagePairs pairs;
  std::set<std::pair<size_t, size_t>> seen;
  auto add = [&](size_t a, size_t b) {
    if (b < names.size() && b != a && seen.insert({a, b}).second) pairs.push_back({names[a], names[b]});
  };
  for (size_t a = 0; a < names.size(); ++a) {
    for (int k = 0; k < overlap && a + k < names.size(); ++k) {
      add(a, a + k);
      if (k < 40) add(a, a + (size_t(1) << k));  // 2^40 images: beyond any capture (no shift overflow)
    }
  }
  return pairs;
}

namespace {

struct Descriptors {
  int rows = 0;
  std::vector<uint8_t> data;  // rows x 128, COLMAP's normalised uint8 SIFT
};

std::map<std::string, Descriptors> ReadDescriptors(const std::string& database) {
  std::map<long, std::string> names;
  QueryColmapDatabase(database, "SELECT image_id, name FROM images", [&](sqlite3_stmt* s) {
    names[sqlite3_column_int64(s, 0)] = reinterpret_cast<const char*>(sqlite3_column_text(s, 1));
  });
  std::map<std::string, Descriptors> descriptors;
  QueryColmapDatabase(database, "SELECT image_id, rows, cols, data FROM descriptors", [&](sqlite3_stmt* s) {
    const auto name = names.find(sqlite3_column_int64(s, 0));
    const int rows = sqlite3_column_int(s, 1), cols = sqlite3_column_int(s, 2);
    RELIT_REQUIRE(name != names.end() && cols == 128 && sqlite3_column_bytes(s, 3) == rows * cols,
                  "COLMAP database ", database, ": unexpected descriptor block (", rows, " x ", cols,
                  "); was it written by Debian's colmap 3.8?");
    Descriptors& d = descriptors[name->second];
    d.rows = rows;
    d.data.resize(static_cast<size_t>(rows) * cols);
    if (rows > 0) std::memcpy(d.data.data(), sqlite3_column_blob(s, 3), d.data.size());
  });
  return descriptors;
}

// Rows as unit float vectors: the dot product of two is the cosine of their
// angle. Converted per pair (each image ~10 times, ~5 % of a pair's time)
// rather than once for all: float descriptors of a 20,000-frame capture
// would take ~7 GB.
cv::Mat UnitRows(const Descriptors& d) {
  if (d.rows == 0) return {};
  cv::Mat out;
  cv::Mat(d.rows, 128, CV_8U, const_cast<uint8_t*>(d.data.data())).convertTo(out, CV_32F);
  for (int r = 0; r < out.rows; ++r) {
    const double norm = cv::norm(out.row(r));
    if (norm > 0) out.row(r) /= norm;
  }
  return out;
}

// The best and second-best dot product of one descriptor against the other
// image's, with the best's index.
struct BestTwo {
  float best = -2, second = -2;
  int index = -1;
  void Offer(float dot, int i) {
    if (dot > best) {
      second = best, best = dot, index = i;
    } else if (dot > second) {
      second = dot;
    }
  }
  // COLMAP's tests, on descriptor angles.
  int Match(const DescriptorMatchOptions& o) const {
    if (index < 0) return -1;
    const double angle = std::acos(std::clamp(static_cast<double>(best), -1.0, 1.0));
    const double second_angle = std::acos(std::clamp(static_cast<double>(second), -1.0, 1.0));
    if (angle > o.max_angle || angle >= o.max_ratio * second_angle) return -1;
    return index;
  }
};

// One matrix product gives every descriptor angle of the pair, both ways.
std::vector<std::pair<int, int>> MatchPair(const cv::Mat& a, const cv::Mat& b, const DescriptorMatchOptions& o) {
  std::vector<std::pair<int, int>> matches;
  if (a.empty() || b.empty()) return matches;
  cv::Mat dots;
  cv::gemm(a, b, 1.0, cv::noArray(), 0.0, dots, cv::GEMM_2_T);
  std::vector<BestTwo> rows(a.rows), columns(b.rows);
  for (int i = 0; i < a.rows; ++i) {
    const float* row = dots.ptr<float>(i);
    for (int j = 0; j < b.rows; ++j) {
      rows[i].Offer(row[j], j);
      columns[j].Offer(row[j], i);
    }
  }
  for (int i = 0; i < a.rows; ++i) {
    const int j = rows[i].Match(o);
    if (j >= 0 && (!o.cross_check || columns[j].Match(o) == i)) matches.push_back({i, j});
  }
  return matches;
}

}  // namespace

MatchedPairs MatchDescriptors(const std::string& database, const ImagePairs& pairs,
                              const DescriptorMatchOptions& options, DescriptorMatchStats* stats) {
  const auto start = std::chrono::steady_clock::now();
  const std::map<std::string, Descriptors> descriptors = ReadDescriptors(database);
  // An image COLMAP could not read has no descriptors: its pairs are left
  // out, and calib reports the frame as unregistered with 0 features.
  *stats = {};
  MatchedPairs matched;
  for (const auto& pair : pairs) {
    if (descriptors.count(pair.first) && descriptors.count(pair.second)) {
      matched.pairs.push_back(pair);
    } else {
      ++stats->pairs_without_descriptors;
    }
  }
  matched.matches.resize(matched.pairs.size());
  auto run = [&] {
    tbb::parallel_for(size_t(0), matched.pairs.size(), [&](size_t i) {
      const cv::Mat a = UnitRows(descriptors.at(matched.pairs[i].first));
      const cv::Mat b = UnitRows(descriptors.at(matched.pairs[i].second));
      matched.matches[i] = MatchPair(a, b, options);
    });
  };
  if (options.threads > 0) {
    tbb::task_arena(options.threads).execute(run);
  } else {
    run();
  }
  for (const auto& m : matched.matches) stats->matches += static_cast<long>(m.size());
  stats->pairs = static_cast<int>(matched.pairs.size());
  stats->seconds = SecondsSince(start);
  return matched;
}

void WriteRawMatches(const MatchedPairs& matched, const std::string& raw_path) {
  std::ofstream out(raw_path);
  RELIT_REQUIRE(static_cast<bool>(out), "cannot write ", raw_path);
  for (size_t i = 0; i < matched.pairs.size(); ++i) {
    out << matched.pairs[i].first << " " << matched.pairs[i].second << "\n";
    for (const auto& [p, q] : matched.matches[i]) out << p << " " << q << "\n";
    out << "\n";
  }
  out.close();
  RELIT_REQUIRE(static_cast<bool>(out), "cannot write ", raw_path, " (disk full?)");
}

}  // namespace relit::calib
