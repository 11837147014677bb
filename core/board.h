// The ChArUco board and the world frame every stage uses.
//
// OpenCV 4.6 places ChArUco object points in the *board* frame: origin at the
// top-left corner of the printed board, x along the printed rows, y running
// down the printed image and +Z pointing into the board (away from the
// viewer). relit's *world* frame is the board frame turned right side up and
// centred: origin at the centre of the printed board, x along the printed
// rows, +Z up out of the table, metres. world_from_board is the only place
// that conversion is written.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/aruco/charuco.hpp>

#include "core/camera.h"
#include "core/option_fields.h"

namespace relit {

struct BoardSpec {
  int squares_x = 7;                 // squares along the printed rows
  int squares_y = 5;                 // squares down the printed image; keep odd (OpenCV 4.6 layout)
  double square_length_m = 0.040;    // metres
  double marker_length_m = 0.030;    // metres
  std::string dictionary = "DICT_APRILTAG_36h11";

  static const OptionFields<BoardSpec>& Fields();
  void Check() const;  // across fields: squares_y odd, marker smaller than square; see CheckOptions
  double width_m() const { return squares_x * square_length_m; }
  double height_m() const { return squares_y * square_length_m; }
  int corner_count() const { return (squares_x - 1) * (squares_y - 1); }
};

// Reads a `board:` options section (squares_x, squares_y, square_length_m,
// marker_length_m, dictionary) and checks it; errors name the file.
void ReadBoardSpec(OptionsReader& reader, BoardSpec* board);

// OpenCV predefined dictionary id for a name like "DICT_APRILTAG_36h11".
int DictionaryId(const std::string& name);
// The names DictionaryId knows.
std::vector<std::string> DictionaryNames();

cv::Ptr<cv::aruco::CharucoBoard> MakeCharucoBoard(const BoardSpec& spec);

// The rigid transform taking OpenCV board coordinates to world coordinates:
// a half turn about x (printed y runs down -> world y runs up the print,
// +Z into the board -> +Z up)
// followed by moving the board centre to the origin.
Rigid3 WorldFromBoard(const BoardSpec& spec);

// ChArUco inner-corner positions in world coordinates, indexed by corner id.
std::vector<Eigen::Vector3d> CharucoCornersWorld(const BoardSpec& spec);

// Renders the printable board image (8-bit grey), `pixels_per_metre` scale,
// white margin of `margin_px` pixels on each side.
cv::Mat DrawBoardImage(const BoardSpec& spec, double pixels_per_metre, int margin_px);

}  // namespace relit
