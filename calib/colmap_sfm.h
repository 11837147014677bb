// Structure from motion with the COLMAP command line (Debian's colmap 3.8,
// CPU only): feature extraction per phone with its board-calibrated lens,
// matching of sequential pairs in each phone's frame order and of
// cross-phone pairs ("loop closure" between the two phones), by OpenCV
// (feature_matching.h) and verified in process (pair_verification.h) or
// by COLMAP, or by COLMAP alone; then
// either the incremental mapper ("incremental") or, with the board's poses
// as known poses ("board_seeded"), point_triangulator on those poses and
// image_registrator for the frames the board cannot place; and a text
// export of the largest model. The SQLite
// database and the text model are read back in C++. Pixel coordinates are
// converted from COLMAP's (0.5, 0.5) to relit's (0, 0) top-left pixel
// centre.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/camera.h"

struct sqlite3;
struct sqlite3_stmt;

namespace relit::calib {

struct SfmImage {
  std::string name;        // COLMAP image name relative to the image folder, e.g. "view/000003.png"
  std::string device;      // "view" or "light"
};

struct SfmRunOptions {
  std::string colmap = "colmap";
  std::string image_dir;   // folder the image names are relative to
  std::string work_dir;    // database, logs and models go here
  int sequential_overlap = 10;
  int ransac_trials = 1000;  // geometric verification of each pair
  int threads = 0;
  int min_registered = 6;
  int max_features = 8192;  // SIFT features per image (COLMAP's default)
  int first_octave = -1;    // SIFT's first octave (COLMAP's default -1: the image doubled first)
  double mapper_global_ba_growth = 1.4;   // Mapper.ba_global_images_ratio and ba_global_points_ratio
  int mapper_global_ba_refinements = 2;   // Mapper.ba_global_max_refinements
  // "opencv": descriptors matched by OpenCV (calib/feature_matching.h), then
  // verified by COLMAP; "colmap": COLMAP's own sequential_matcher and
  // matches_importer (FLANN, ~10x slower per pair on the CPU).
  std::string matcher = "opencv";
  // With matcher "opencv": "opencv" verifies the pairs in process
  // (calib/pair_verification.h, all cores), "colmap" by COLMAP's
  // matches_importer (one core, ~10 ms per pair).
  std::string verification = "opencv";
  // Known cam_from_world poses by image name (board_seeded); empty: the
  // incremental mapper builds the model from scratch.
  std::map<std::string, Rigid3> known_poses;
  // A previous run's COLMAP folder (database.db, sparse/): its model is read
  // and no COLMAP step runs. For measuring the refinement alone.
  std::string reuse_dir;
};

struct SfmTrackObservation {
  std::string image;            // image name
  Eigen::Vector2d pixel_px;     // OpenCV convention
};

struct SfmModel {
  std::map<std::string, Rigid3> cam_from_model;   // by image name
  std::vector<Eigen::Vector3d> points;
  std::vector<std::vector<SfmTrackObservation>> tracks;
};

struct SfmResult {
  SfmModel model;                                  // the largest model
  int images = 0;
  int models = 0;
  std::vector<int> model_sizes;                    // registered images per model
  std::map<std::string, int> registered_by_device;
  std::map<std::string, int> keypoints;            // per image, from the database
  int verified_pairs = 0;                          // image pairs with geometrically verified matches
  std::map<std::string, std::string> unregistered; // image -> likely reason
  std::map<std::string, double> timings_s;         // per COLMAP step
  double descriptor_matching_s = 0;                // relit's own matching (matcher "opencv"), not a COLMAP step
  double pair_verification_s = 0;                  // relit's own verification (verification "opencv")
};

// Runs COLMAP. Lenses are given per device (OPENCV model, fixed during
// mapping). `pairs` are extra image pairs to match (names). With
// known_poses, those images keep their poses (the model is then in their
// frame, not an arbitrary one) and the rest are registered to the points
// triangulated from them. Throws
// relit::Error when a COLMAP step fails or registers fewer than
// min_registered images, naming the step and its log file.
SfmResult RunColmapSfm(const std::vector<SfmImage>& images,
                       const std::map<std::string, Intrinsics>& lenses,
                       const std::vector<std::pair<std::string, std::string>>& pairs,
                       const SfmRunOptions& options);

// Readers of COLMAP's text model (cameras are not needed: lenses are relit's).
SfmModel ReadColmapTextModel(const std::string& dir);

// Keypoint counts per image name and the number of verified pairs in a
// COLMAP database.
void ReadColmapDatabase(const std::string& path, std::map<std::string, int>* keypoints,
                        int* verified_pairs);

// Opens a COLMAP database (sqlite3_close it); throws relit::Error naming it
// when it cannot be opened.
sqlite3* OpenColmapDatabase(const std::string& path, bool writable);

// Runs one SQL query on a COLMAP database (read-only), calling `row` per row.
void QueryColmapDatabase(const std::string& path, const char* sql, const std::function<void(sqlite3_stmt*)>& row);

// COLMAP's image and camera ids by image name, from a database.
struct ColmapIds {
  long image_id = 0;
  long camera_id = 0;
};
std::map<std::string, ColmapIds> ReadColmapImageIds(const std::string& path);

// Writes a COLMAP text model (cameras.txt, images.txt, points3D.txt) in
// COLMAP's pixel convention. Cameras: one per device, numbered from 1 in
// map order; images in the given order.
void WriteColmapTextModel(const std::string& dir, const std::map<std::string, Intrinsics>& lenses,
                          const std::vector<std::pair<std::string, std::string>>& image_devices,
                          const std::vector<Rigid3>& cam_from_world,
                          const std::vector<Eigen::Vector3d>& points);

}  // namespace relit::calib
