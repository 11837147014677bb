// View-direction partitions of Deferred Neural Lighting.
//
// DNL splits the hemisphere of view directions into overlapping partitions:
// one neural texture + networks per vertex of a triangulated set of
// directions. A training frame belongs to the partitions of the three
// vertices of the triangle its view direction falls in; at render time the
// same triangle's three partitions are blended with barycentric weights.
//
// Directions are unit vectors in the world frame (+Z up), pointing from the
// object centre towards the camera. Elevation is the angle above the XY plane
// (0 = horizon, 90 deg = zenith); azimuth is measured from +X towards +Y.
//
// Triangulation: the convex hull of the vertices plus a virtual vertex at the
// nadir (0, 0, -1). For points on the unit sphere the hull is the spherical
// Delaunay triangulation, and its faces' cones tile the whole sphere. Faces
// that touch the nadir cover the "open bottom" (below the horizon, or below
// the lowest ring of a custom layout); there the nadir's weight is dropped and
// the other two renormalised, which is the same as clamping the direction up
// onto the edge between them. Weights are therefore continuous everywhere.
// The hull is computed by brute force (O(n^4), fine for the <= 256 vertices
// allowed); no CGAL needed.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/option_fields.h"

namespace relit::relight {

struct PartitionLayoutOptions {
  // "dnl13": zenith, 6 vertices at 30 deg elevation every 60 deg, 6 on the
  //          horizon offset by 30 deg (13 vertices, 18 triangles), as in DNL.
  // "single": one partition holding every frame (small captures, tests).
  // "custom": the vertices below.
  std::string layout = "dnl13";
  std::vector<double> elevation_deg;  // custom only, in [-90, 90]
  std::vector<double> azimuth_deg;    // custom only, same length

  // The JSON (OptionsToJson) holds the vertex lists only for custom.
  static const OptionFields<PartitionLayoutOptions>& Fields();
  void Check() const;  // across fields; choices: CheckOptions
};

// The inverse of OptionsToJson(PartitionLayoutOptions) (absent vertex lists = empty).
// Throws relit::Error naming `where` when "layout" is missing.
PartitionLayoutOptions PartitionLayoutOptionsFromJson(const nlohmann::json& j, const std::string& where);

// Blend of up to three partitions for one view direction.
struct PartitionBlend {
  int count = 0;                          // 1 (single layout), 2 or 3
  std::array<int, 3> partition{-1, -1, -1};
  std::array<double, 3> weight{0, 0, 0};  // >= 0, sum to 1 over `count`
};

class PartitionLayout {
 public:
  static constexpr int kMaxVertices = 256;

  static PartitionLayout FromOptions(const PartitionLayoutOptions& options);
  static PartitionLayout Dnl13();
  static PartitionLayout Single();
  // Vertices are normalised; they must be distinct (>= 0.5 deg apart) and,
  // for more than one vertex, their hull with the nadir must strictly enclose
  // the sphere's centre (in practice: vertices spread over the hemisphere,
  // not all on one great circle). Throws relit::Error otherwise.
  static PartitionLayout FromVertices(std::vector<Eigen::Vector3d> vertices);

  int partition_count() const { return static_cast<int>(vertices_.size()); }
  const std::vector<Eigen::Vector3d>& vertices() const { return vertices_; }
  // Triangles between real vertices, counter-clockwise seen from outside.
  const std::vector<std::array<int, 3>>& triangles() const { return triangles_; }

  // Barycentric blend for a view direction (need not be normalised, must not
  // be zero).
  PartitionBlend Blend(const Eigen::Vector3d& direction) const;

  // Partitions a training frame with this view direction belongs to: the
  // vertices of the triangle the direction falls in (after clamping it up
  // onto the covered region when it lies in a nadir face).
  std::vector<int> PartitionsOf(const Eigen::Vector3d& direction) const;

  // For each partition, the indices of the frames (by view direction) it
  // holds. Every frame lands in at least one partition.
  std::vector<std::vector<int>> AssignFrames(const std::vector<Eigen::Vector3d>& directions) const;

  // {"vertices": [[x,y,z]...], "elevation_deg": [...], "azimuth_deg": [...],
  //  "triangles": [[a,b,c]...]}
  nlohmann::json ToJson() const;

 private:
  struct Face {
    std::array<int, 3> vertex;  // kNadir marks the virtual vertex
    Eigen::Matrix3d inverse;    // maps a direction to cone coordinates
    int triangle = -1;          // real face: its index in triangles_;
                                // nadir face: the real triangle across its real edge (-1 if none)
  };
  static constexpr int kNadir = -1;

  // The face whose cone contains `direction` (largest smallest coordinate,
  // robust on edges) and the direction's cone coordinates in it.
  const Face& Locate(const Eigen::Vector3d& direction, Eigen::Vector3d* coords) const;

  std::vector<Eigen::Vector3d> vertices_;
  std::vector<std::array<int, 3>> triangles_;
  std::vector<Face> faces_;  // real faces first, then nadir faces
};

// Unit direction from elevation/azimuth in degrees.
Eigen::Vector3d DirectionFromElevationAzimuthDeg(double elevation_deg, double azimuth_deg);

// The object and its partition layout: what plan.json records and an asset's
// manifest.json takes from the plan (Plan and AssetDescription derive from it).
struct ObjectLayout {
  PartitionLayoutOptions layout_options;
  Eigen::Vector3d object_centre_m = Eigen::Vector3d::Zero();  // view directions are measured from here
  double object_radius_m = 0;

  PartitionLayout Layout() const { return PartitionLayout::FromOptions(layout_options); }
};

// {layout_options, layout (derived, for other readers), object_centre_m,
// object_radius_m}, and the inverse (throws relit::Error naming `path`).
nlohmann::json ObjectLayoutJson(const ObjectLayout& object);
void ReadObjectLayout(const nlohmann::json& j, const std::string& path, ObjectLayout* object);

}  // namespace relit::relight
