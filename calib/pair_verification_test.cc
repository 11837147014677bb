#include "calib/pair_verification.h"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <random>
#include <set>

#include <gtest/gtest.h>
#include <sqlite3.h>

#include "calib/colmap_sfm.h"
#include "core/shell.h"
#include "core/test_dir.h"

namespace relit::calib {
namespace {

// Two views of random points 0.4-0.6 m away, 6 cm apart, 12 degrees turned.
struct TwoViews {
  Rigid3 first, second;  // cam_from_world
  std::vector<Eigen::Vector3d> points;
};

TwoViews MakeScene(std::mt19937& rng, int count) {
  TwoViews scene;
  scene.first = Rigid3(Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero());
  scene.second = Rigid3(Eigen::Quaterniond(Eigen::AngleAxisd(0.21, Eigen::Vector3d::UnitY())),
                        Eigen::Vector3d(-0.06, 0.005, 0.01));
  std::uniform_real_distribution<double> u(-0.15, 0.15), depth(0.4, 0.6);
  for (int i = 0; i < count; ++i) scene.points.emplace_back(u(rng), u(rng), depth(rng));
  return scene;
}

Eigen::Vector2d Project(const Rigid3& cam_from_world, const Eigen::Vector3d& point) {
  const Eigen::Vector3d p = cam_from_world.rotation * point + cam_from_world.translation;
  return p.head<2>() / p.z();
}

constexpr double kFocalPx = 500;

// Matched normalised coordinates: `inliers` true correspondences with 0.3 px
// of noise, then `outliers` matches to unrelated image positions.
struct Matches {
  std::vector<Eigen::Vector2d> a, b;
  std::vector<std::pair<int, int>> pairs;
};

Matches MakeMatches(std::mt19937& rng, int inliers, int outliers) {
  const TwoViews scene = MakeScene(rng, inliers);
  std::normal_distribution<double> noise(0, 0.3 / kFocalPx);
  std::uniform_real_distribution<double> anywhere(-0.4, 0.4);
  Matches m;
  for (const Eigen::Vector3d& p : scene.points) {
    m.a.push_back(Project(scene.first, p) + Eigen::Vector2d(noise(rng), noise(rng)));
    m.b.push_back(Project(scene.second, p) + Eigen::Vector2d(noise(rng), noise(rng)));
  }
  for (int i = 0; i < outliers; ++i) {
    m.a.emplace_back(anywhere(rng), anywhere(rng));
    m.b.emplace_back(anywhere(rng), anywhere(rng));
  }
  for (int i = 0; i < inliers + outliers; ++i) m.pairs.push_back({i, i});
  return m;
}

TEST(EssentialInliersTest, KeepsTheTrueMatchesAndRejectsTheRest) {
  std::mt19937 rng(3);
  const Matches m = MakeMatches(rng, 150, 60);
  const std::vector<int> inliers = EssentialInliers(m.a, m.b, m.pairs, 4.0 / kFocalPx, {});
  int true_kept = 0, false_kept = 0;
  for (int k : inliers) (k < 150 ? true_kept : false_kept)++;
  EXPECT_GE(true_kept, 147) << "true matches lost";
  // An unrelated match passes only when it falls within 4 px of its epipolar
  // line (~2 % of the image here).
  EXPECT_LE(false_kept, 4) << "outliers accepted";
}

TEST(EssentialInliersTest, TooFewAgreeingMatchesLeaveThePairUnverified) {
  std::mt19937 rng(4);
  const Matches few = MakeMatches(rng, 12, 0);
  EXPECT_TRUE(EssentialInliers(few.a, few.b, few.pairs, 4.0 / kFocalPx, {}).empty());
  const Matches noise = MakeMatches(rng, 0, 80);
  EXPECT_TRUE(EssentialInliers(noise.a, noise.b, noise.pairs, 4.0 / kFocalPx, {}).empty());
}

class VerifyAndStoreTest : public test_support::TempDirTest {
 protected:
  VerifyAndStoreTest() : TempDirTest("relit_pair_verification_") {}
};

void Sql(sqlite3* db, const std::string& sql) {
  ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK) << sql << ": " << sqlite3_errmsg(db);
}

// COLMAP's own schema (colmap database_creator), COLMAP's keypoint layout
// (x, y + 4 affine values, (0.5, 0.5) at the top-left pixel centre) and a
// distorted lens; image ids in the reverse of the pair's name order, so the
// stored pair is the swapped one.
TEST_F(VerifyAndStoreTest, WritesColmapsPairLayout) {
  const std::string database = (root_ / "database.db").string();
  ASSERT_EQ(std::system(("QT_QPA_PLATFORM=offscreen colmap database_creator --database_path " +
                         ShellQuote(database) + " > /dev/null 2>&1").c_str()),
            0)
      << "colmap database_creator failed (tools/install-deps)";
  Intrinsics lens;
  lens.width = 640, lens.height = 480, lens.fx = lens.fy = kFocalPx, lens.cx = 319.5, lens.cy = 239.5;
  lens.distortion.k1 = -0.12, lens.distortion.k2 = 0.03;
  std::mt19937 rng(5);
  const TwoViews scene = MakeScene(rng, 120);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(database.c_str(), &db), SQLITE_OK);
  Sql(db, "INSERT INTO cameras VALUES (1, 4, 640, 480, NULL, 0)");
  Sql(db, "INSERT INTO images (image_id, name, camera_id) VALUES (1, 'b.png', 1), (2, 'a.png', 1)");
  for (const auto& [id, pose] : {std::pair<int, Rigid3>{2, scene.first}, {1, scene.second}}) {
    std::vector<float> rows;
    for (const Eigen::Vector3d& p : scene.points) {
      const Eigen::Vector2d d = Distort(lens.distortion, Project(pose, p));
      rows.insert(rows.end(), {float(lens.fx * d.x() + lens.cx + 0.5), float(lens.fy * d.y() + lens.cy + 0.5), 1,
                               0, 0, 1});
    }
    sqlite3_stmt* s = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "INSERT INTO keypoints VALUES (?, ?, 6, ?)", -1, &s, nullptr), SQLITE_OK);
    sqlite3_bind_int(s, 1, id);
    sqlite3_bind_int(s, 2, static_cast<int>(scene.points.size()));
    sqlite3_bind_blob(s, 3, rows.data(), static_cast<int>(rows.size() * sizeof(float)), SQLITE_TRANSIENT);
    ASSERT_EQ(sqlite3_step(s), SQLITE_DONE);
    sqlite3_finalize(s);
  }
  sqlite3_close(db);

  // Pair (a, b): a's keypoint i matches b's keypoint i; the last 20 are mismatched.
  MatchedPairs matched;
  matched.pairs = {{"a.png", "b.png"}};
  matched.matches.resize(1);
  for (int i = 0; i < 100; ++i) matched.matches[0].push_back({i, i});
  for (int i = 100; i < 120; ++i) matched.matches[0].push_back({i, 100 + (i - 100 + 7) % 20});
  const PairVerificationStats stats =
      VerifyAndStorePairs(database, matched, {{"a.png", lens}, {"b.png", lens}}, {});
  EXPECT_EQ(stats.verified_pairs, 1);
  EXPECT_EQ(stats.matches, 120);
  EXPECT_GE(stats.inliers, 98);
  EXPECT_LE(stats.inliers, 102);

  int rows = -1, config = -1, match_rows = -1;
  int64_t pair_id = 0;
  std::vector<uint32_t> data;
  std::vector<double> essential;
  QueryColmapDatabase(database, "SELECT pair_id, rows, cols, data, config, E FROM two_view_geometries",
                      [&](sqlite3_stmt* s) {
    pair_id = sqlite3_column_int64(s, 0);
    rows = sqlite3_column_int(s, 1);
    EXPECT_EQ(sqlite3_column_int(s, 2), 2);
    data.resize(static_cast<size_t>(rows) * 2);
    std::memcpy(data.data(), sqlite3_column_blob(s, 3), data.size() * 4);
    config = sqlite3_column_int(s, 4);
    essential.resize(9);
    std::memcpy(essential.data(), sqlite3_column_blob(s, 5), 9 * 8);
  });
  QueryColmapDatabase(database, "SELECT rows FROM matches", [&](sqlite3_stmt* s) { match_rows = sqlite3_column_int(s, 0); });
  EXPECT_EQ(pair_id, 2147483647LL * 1 + 2) << "COLMAP's pair id: the smaller image id first";
  EXPECT_EQ(config, 2) << "CALIBRATED";
  EXPECT_EQ(match_rows, 120);
  EXPECT_EQ(rows, stats.inliers);
  // Columns follow COLMAP's order (b first), and E maps b's rays to a's.
  const Eigen::Matrix3d e = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(essential.data());
  int correct = 0;
  for (int r = 0; r < rows; ++r) {
    const uint32_t in_b = data[2 * r], in_a = data[2 * r + 1];
    if (in_a != in_b) continue;
    ++correct;
    const Eigen::Vector3d xb = Project(scene.second, scene.points[in_b]).homogeneous();
    const Eigen::Vector3d xa = Project(scene.first, scene.points[in_a]).homogeneous();
    EXPECT_LT(std::abs(xa.dot(e * xb)) / (e * xb).head<2>().norm() * kFocalPx, 0.5) << "row " << r;
  }
  EXPECT_GE(correct, 98);
}

}  // namespace
}  // namespace relit::calib
