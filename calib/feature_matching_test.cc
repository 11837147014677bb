#include "calib/feature_matching.h"

#include <algorithm>
#include <fstream>
#include <cmath>
#include <random>
#include <set>
#include <sstream>

#include <gtest/gtest.h>
#include <sqlite3.h>

#include "core/test_dir.h"

namespace relit::calib {
namespace {

TEST(SequentialPairsTest, FollowsColmapsSequentialMatcher) {
  // COLMAP 3.8 with overlap 3 matched offsets 1, 2 and 4 in name order on
  // the 990-image capture (its database, 11-27 lab); names arrive unsorted.
  const std::vector<std::string> names = {"b/02", "a/00", "b/00", "a/01", "b/01", "a/02"};
  const ImagePairs pairs = SequentialPairs(names, 3);
  std::set<std::pair<std::string, std::string>> got(pairs.begin(), pairs.end());
  EXPECT_EQ(got.size(), pairs.size()) << "a pair twice";
  const std::vector<std::string> sorted = {"a/00", "a/01", "a/02", "b/00", "b/01", "b/02"};
  std::set<std::pair<std::string, std::string>> want;
  for (size_t i = 0; i < sorted.size(); ++i) {
    for (size_t offset : {1, 2, 4}) {
      if (i + offset < sorted.size()) want.insert({sorted[i], sorted[i + offset]});
    }
  }
  EXPECT_EQ(got, want);
}

// Unit-length random descriptors stored as COLMAP does (x 512, uint8).
std::vector<uint8_t> Quantise(const std::vector<std::vector<float>>& rows) {
  std::vector<uint8_t> out;
  for (const std::vector<float>& row : rows) {
    for (float v : row) out.push_back(static_cast<uint8_t>(std::clamp(std::lround(512 * v), 0L, 255L)));
  }
  return out;
}

std::vector<float> RandomUnit(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0, 1);
  std::vector<float> v(128);
  double norm = 0;
  for (float& x : v) x = u(rng) * u(rng), norm += x * x;
  for (float& x : v) x /= static_cast<float>(std::sqrt(norm));
  return v;
}

void WriteDatabase(const std::string& path, const std::vector<std::vector<uint8_t>>& images) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db,
                         "CREATE TABLE images (image_id INTEGER PRIMARY KEY, name TEXT);"
                         "CREATE TABLE descriptors (image_id INTEGER PRIMARY KEY, rows INTEGER, cols INTEGER, "
                         "data BLOB);",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  for (size_t i = 0; i < images.size(); ++i) {
    const std::string insert = "INSERT INTO images VALUES (" + std::to_string(i + 1) + ", 'img" +
                                std::to_string(i) + ".png')";
    ASSERT_EQ(sqlite3_exec(db, insert.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_stmt* s = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "INSERT INTO descriptors VALUES (?, ?, 128, ?)", -1, &s, nullptr), SQLITE_OK);
    sqlite3_bind_int(s, 1, static_cast<int>(i + 1));
    sqlite3_bind_int(s, 2, static_cast<int>(images[i].size() / 128));
    sqlite3_bind_blob(s, 3, images[i].data(), static_cast<int>(images[i].size()), SQLITE_TRANSIENT);
    ASSERT_EQ(sqlite3_step(s), SQLITE_DONE);
    sqlite3_finalize(s);
  }
  sqlite3_close(db);
}

class MatchDescriptorsTest : public test_support::TempDirTest {
 protected:
  MatchDescriptorsTest() : TempDirTest("relit_feature_matching_") {}
};

TEST_F(MatchDescriptorsTest, FindsThePermutedFeaturesAndDropsAmbiguousOnes) {
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0, 0.01f);
  // Image 0: 60 features. Image 1: 40 of them, shuffled and slightly
  // perturbed, 30 unrelated ones, and a near-copy of feature 5 of image 0
  // beside its true match (ambiguous: the ratio test must drop it).
  std::vector<std::vector<float>> first, second;
  for (int i = 0; i < 60; ++i) first.push_back(RandomUnit(rng));
  std::vector<int> order(40);
  for (int i = 0; i < 40; ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<std::pair<int, int>> truth;
  for (int j = 0; j < 40; ++j) {
    std::vector<float> v = first[order[j]];
    for (float& x : v) x = std::max(0.0f, x + noise(rng));
    second.push_back(v);
    if (order[j] != 5) truth.push_back({order[j], j});
  }
  for (int j = 0; j < 30; ++j) second.push_back(RandomUnit(rng));
  std::vector<float> twin = first[5];
  for (float& x : twin) x = std::max(0.0f, x + noise(rng));
  second.push_back(twin);

  const std::string database = (root_ / "database.db").string();
  WriteDatabase(database, {Quantise(first), Quantise(second)});
  DescriptorMatchStats stats;
  const MatchedPairs matched = MatchDescriptors(database, {{"img0.png", "img1.png"}}, {}, &stats);
  EXPECT_EQ(stats.pairs, 1);
  // Read back from the raw file COLMAP's matches_importer would take.
  const std::string raw = (root_ / "raw.txt").string();
  WriteRawMatches(matched, raw);

  std::ifstream in(raw);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "img0.png img1.png");
  std::set<std::pair<int, int>> got;
  std::string line;
  while (std::getline(in, line) && !line.empty()) {
    std::istringstream s(line);
    int a, b;
    ASSERT_TRUE(static_cast<bool>(s >> a >> b)) << line;
    got.insert({a, b});
  }
  EXPECT_EQ(stats.matches, static_cast<long>(got.size()));
  const std::set<std::pair<int, int>> want(truth.begin(), truth.end());
  EXPECT_EQ(got, want);
}

// An image COLMAP could not read has no descriptors: its pairs are left
// out (calib then reports the frame with 0 features), the others matched.
TEST_F(MatchDescriptorsTest, LeavesOutPairsOfImagesWithoutDescriptors) {
  const std::string database = (root_ / "database.db").string();
  std::mt19937 rng(1);
  std::vector<std::vector<float>> features;
  for (int i = 0; i < 10; ++i) features.push_back(RandomUnit(rng));
  WriteDatabase(database, {Quantise(features), Quantise(features)});
  DescriptorMatchStats stats;
  const MatchedPairs matched =
      MatchDescriptors(database, {{"img0.png", "img9.png"}, {"img0.png", "img1.png"}}, {}, &stats);
  EXPECT_EQ(stats.pairs, 1);
  EXPECT_EQ(stats.pairs_without_descriptors, 1);
  EXPECT_EQ(stats.matches, 10);
  ASSERT_EQ(matched.pairs.size(), 1u);
  EXPECT_EQ(matched.pairs[0], std::make_pair(std::string("img0.png"), std::string("img1.png")));
  EXPECT_EQ(matched.matches[0].size(), 10u);
}

}  // namespace
}  // namespace relit::calib
