#include "core/board.h"

#include <map>

#include "core/error.h"

namespace relit {

RELIT_OPTION_FIELDS(BoardSpec,
    .Add("squares_x", &S::squares_x, 3, 100, "squares along the printed rows")
    .Add("squares_y", &S::squares_y, 3, 100,
         "squares down the printed image; odd (OpenCV 4.6 changed the layout for even rows)")
    .Add("square_length_m", &S::square_length_m, 1e-4, 1.0, "printed square side, metres (measure it)")
    .Add("marker_length_m", &S::marker_length_m, 1e-4, 1.0,
         "printed marker side, metres; smaller than the square")
    .Add("dictionary", &S::dictionary, DictionaryNames(), "the markers' dictionary"))

void BoardSpec::Check() const {
  RELIT_REQUIRE(squares_y % 2 == 1,
                "board squares_y must be odd: OpenCV 4.6 changed the ChArUco layout for an even "
                "number of rows, got ", squares_y);
  RELIT_REQUIRE(marker_length_m > 0 && marker_length_m < square_length_m,
                "board marker_length_m must be positive and smaller than square_length_m, got ",
                marker_length_m);
}

void ReadBoardSpec(OptionsReader& r, BoardSpec* board) {
  ReadOptions(r, board);
  try {
    CheckOptions(*board);
  } catch (const Error& e) {
    Fail(r.file(), ": board: ", e.what());
  }
}

namespace {

const std::map<std::string, int>& DictionaryIds() {
  static const std::map<std::string, int> kIds = {
      {"DICT_4X4_50", cv::aruco::DICT_4X4_50},
      {"DICT_4X4_100", cv::aruco::DICT_4X4_100},
      {"DICT_4X4_250", cv::aruco::DICT_4X4_250},
      {"DICT_5X5_100", cv::aruco::DICT_5X5_100},
      {"DICT_5X5_250", cv::aruco::DICT_5X5_250},
      {"DICT_6X6_250", cv::aruco::DICT_6X6_250},
      {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL},
      {"DICT_APRILTAG_16h5", cv::aruco::DICT_APRILTAG_16h5},
      {"DICT_APRILTAG_25h9", cv::aruco::DICT_APRILTAG_25h9},
      {"DICT_APRILTAG_36h10", cv::aruco::DICT_APRILTAG_36h10},
      {"DICT_APRILTAG_36h11", cv::aruco::DICT_APRILTAG_36h11},
  };
  return kIds;
}

}  // namespace

std::vector<std::string> DictionaryNames() {
  std::vector<std::string> names;
  for (const auto& [name, id] : DictionaryIds()) names.push_back(name);
  return names;
}

int DictionaryId(const std::string& name) {
  const auto it = DictionaryIds().find(name);
  if (it == DictionaryIds().end()) {
    Fail("unknown board dictionary '", name, "' (known: ", internal::JoinChoices(DictionaryNames()), ")");
  }
  return it->second;
}

cv::Ptr<cv::aruco::CharucoBoard> MakeCharucoBoard(const BoardSpec& spec) {
  CheckOptions(spec);
  return cv::aruco::CharucoBoard::create(
      spec.squares_x, spec.squares_y, static_cast<float>(spec.square_length_m),
      static_cast<float>(spec.marker_length_m),
      cv::aruco::getPredefinedDictionary(DictionaryId(spec.dictionary)));
}

Rigid3 WorldFromBoard(const BoardSpec& spec) {
  // Half turn about x: (x, y, z) -> (x, -y, -z).
  const Eigen::Matrix3d flip = Eigen::Vector3d(1, -1, -1).asDiagonal();
  const Eigen::Vector3d board_centre(0.5 * spec.width_m(), 0.5 * spec.height_m(), 0);
  return Rigid3(flip, -(flip * board_centre));
}

std::vector<Eigen::Vector3d> CharucoCornersWorld(const BoardSpec& spec) {
  const auto board = MakeCharucoBoard(spec);
  const Rigid3 world_from_board = WorldFromBoard(spec);
  std::vector<Eigen::Vector3d> corners;
  for (const cv::Point3f& p : board->chessboardCorners) {
    corners.push_back(world_from_board * Eigen::Vector3d(p.x, p.y, p.z));
  }
  return corners;
}

cv::Mat DrawBoardImage(const BoardSpec& spec, double pixels_per_metre, int margin_px) {
  const auto board = MakeCharucoBoard(spec);
  const int width = static_cast<int>(std::lround(spec.width_m() * pixels_per_metre)) + 2 * margin_px;
  const int height = static_cast<int>(std::lround(spec.height_m() * pixels_per_metre)) + 2 * margin_px;
  cv::Mat image;
  board->draw(cv::Size(width, height), image, margin_px, 1);
  return image;
}

}  // namespace relit
