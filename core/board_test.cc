#include "core/board.h"

#include <gtest/gtest.h>

namespace relit {
namespace {

TEST(Board, WorldFrameIsZUpAndCentred) {
  BoardSpec spec;
  const Rigid3 world_from_board = WorldFromBoard(spec);
  // OpenCV board +Z points into the board; in the world it must point down.
  const Eigen::Vector3d into_board = world_from_board.rotation * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(into_board.z(), -1.0, 1e-12);
  // Board x axis is kept.
  EXPECT_NEAR((world_from_board.rotation * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX()).norm(), 0, 1e-12);
  // The board centre is the world origin; the printed top-left corner is at -x, +y.
  EXPECT_LT((world_from_board * Eigen::Vector3d(spec.width_m() / 2, spec.height_m() / 2, 0)).norm(), 1e-12);
  const Eigen::Vector3d top_left = world_from_board * Eigen::Vector3d::Zero();
  EXPECT_NEAR(top_left.x(), -spec.width_m() / 2, 1e-12);
  EXPECT_NEAR(top_left.y(), spec.height_m() / 2, 1e-12);
  // Right-handed: a proper rotation.
  EXPECT_NEAR(world_from_board.rotation.toRotationMatrix().determinant(), 1.0, 1e-12);
}

TEST(Board, CornersLieOnTablePlane) {
  BoardSpec spec;
  const auto corners = CharucoCornersWorld(spec);
  ASSERT_EQ(static_cast<int>(corners.size()), spec.corner_count());
  for (const auto& c : corners) {
    EXPECT_NEAR(c.z(), 0.0, 1e-9);
    EXPECT_LE(std::abs(c.x()), spec.width_m() / 2);
    EXPECT_LE(std::abs(c.y()), spec.height_m() / 2);
  }
  // Corner 0 is OpenCV's first inner corner, one square in from the printed top-left.
  EXPECT_NEAR(corners[0].x(), -spec.width_m() / 2 + spec.square_length_m, 1e-6);
  EXPECT_NEAR(corners[0].y(), spec.height_m() / 2 - spec.square_length_m, 1e-6);
}

TEST(Board, RejectsEvenRowsAndBadSizes) {
  BoardSpec spec;
  spec.squares_y = 6;
  EXPECT_THROW(CheckOptions(spec), std::runtime_error);
  spec = BoardSpec();
  spec.marker_length_m = spec.square_length_m;
  EXPECT_THROW(CheckOptions(spec), std::runtime_error);
  spec = BoardSpec();
  spec.dictionary = "DICT_NOPE";
  EXPECT_THROW(CheckOptions(spec), std::runtime_error);
}

TEST(Board, DrawsImageOfExpectedSize) {
  BoardSpec spec;
  const cv::Mat image = DrawBoardImage(spec, 10000.0, 20);
  EXPECT_EQ(image.cols, 2800 + 40);
  EXPECT_EQ(image.rows, 2000 + 40);
  EXPECT_EQ(image.type(), CV_8UC1);
}

}  // namespace
}  // namespace relit
