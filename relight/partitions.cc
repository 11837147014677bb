#include "relight/partitions.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "core/error.h"
#include "core/json_file.h"
#include "core/options.h"

namespace relit::relight {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
// Plane tolerance for the hull of unit vectors: points closer than this to a
// face plane count as on it (co-circular vertices of symmetric layouts).
constexpr double kPlaneEps = 1e-9;
// Minimum angle between two vertices.
constexpr double kMinSeparationRad = 0.5 * kDegToRad;

struct HullFace {
  std::array<int, 3> vertex;  // indices into the hull's point list
};

// Convex hull of points on the unit sphere by brute force: every plane through
// three points with all points on one side is a face; coplanar groups (more
// than three points on one face plane) become a fan of triangles. Triangles
// are counter-clockwise seen from outside. Fails when the hull does not
// strictly enclose the origin (then some directions would have no face).
std::vector<HullFace> SphereHull(const std::vector<Eigen::Vector3d>& points) {
  const int n = static_cast<int>(points.size());
  std::set<std::vector<int>> seen;
  std::vector<HullFace> faces;
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      for (int k = j + 1; k < n; ++k) {
        Eigen::Vector3d normal = (points[j] - points[i]).cross(points[k] - points[i]);
        if (normal.norm() < 1e-12) continue;  // collinear
        normal.normalize();
        bool above = false, below = false;
        std::vector<int> on_plane;
        for (int m = 0; m < n; ++m) {
          const double s = normal.dot(points[m] - points[i]);
          if (s > kPlaneEps) {
            above = true;
          } else if (s < -kPlaneEps) {
            below = true;
          } else {
            on_plane.push_back(m);
          }
          if (above && below) break;
        }
        if (above && below) continue;
        RELIT_REQUIRE(above || below,
                      "partition layout: all vertices lie in one plane; spread them over the "
                      "hemisphere");
        if (above) normal = -normal;  // outward: every other point below the plane
        if (!seen.insert(on_plane).second) continue;
        RELIT_REQUIRE(normal.dot(points[i]) > 1e-6,
                      "partition layout: the vertices (with the virtual nadir) do not surround "
                      "the centre of the sphere, so some view directions would belong to no "
                      "triangle; spread the vertices over the whole hemisphere");
        // Order the coplanar points counter-clockwise around the normal and fan.
        Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
        for (int m : on_plane) centroid += points[m];
        centroid /= static_cast<double>(on_plane.size());
        const Eigen::Vector3d e1 = (points[on_plane[0]] - centroid).normalized();
        const Eigen::Vector3d e2 = normal.cross(e1);
        std::vector<std::pair<double, int>> ordered;
        for (int m : on_plane) {
          const Eigen::Vector3d d = points[m] - centroid;
          ordered.emplace_back(std::atan2(d.dot(e2), d.dot(e1)), m);
        }
        std::sort(ordered.begin(), ordered.end());
        for (size_t t = 1; t + 1 < ordered.size(); ++t) {
          faces.push_back({{ordered[0].second, ordered[t].second, ordered[t + 1].second}});
        }
      }
    }
  }
  return faces;
}

}  // namespace

Eigen::Vector3d DirectionFromElevationAzimuthDeg(double elevation_deg, double azimuth_deg) {
  const double el = elevation_deg * kDegToRad, az = azimuth_deg * kDegToRad;
  return {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
}

PartitionLayoutOptions PartitionLayoutOptionsFromJson(const nlohmann::json& j, const std::string& where) {
  PartitionLayoutOptions options;
  options.layout = JsonField(j, "layout", where).get<std::string>();
  options.elevation_deg = j.value("elevation_deg", std::vector<double>{});
  options.azimuth_deg = j.value("azimuth_deg", std::vector<double>{});
  return options;
}

nlohmann::json ObjectLayoutJson(const ObjectLayout& object) {
  return {{"layout_options", OptionsToJson(object.layout_options)},
          {"layout", object.Layout().ToJson()},
          {"object_centre_m", ToJson(object.object_centre_m)},
          {"object_radius_m", object.object_radius_m}};
}

void ReadObjectLayout(const nlohmann::json& j, const std::string& path, ObjectLayout* object) {
  object->layout_options = PartitionLayoutOptionsFromJson(JsonField(j, "layout_options", path), path);
  object->object_centre_m = Vector3FromJson(JsonField(j, "object_centre_m", path), path);
  object->object_radius_m = JsonNumber(j, "object_radius_m", path);
}

RELIT_OPTION_FIELDS(PartitionLayoutOptions,
    .Add("layout", &S::layout, {"dnl13", "single", "custom"},
         "dnl13: 13 vertices, 18 triangles, as in DNL; single: one partition holding every frame; custom: "
         "the vertices below")
    .Add("elevation_deg", &S::elevation_deg, "custom only: the vertices' elevations, in [-90, 90]")
    .Add("azimuth_deg", &S::azimuth_deg, "custom only: their azimuths, same length")
    .OnToJson([](const S& s, nlohmann::json* json) {
      if (s.layout != "custom") {
        json->erase("elevation_deg");
        json->erase("azimuth_deg");
      }
    }))

void PartitionLayoutOptions::Check() const {
  if (layout != "custom") {
    RELIT_REQUIRE(elevation_deg.empty() && azimuth_deg.empty(),
                  "elevation_deg/azimuth_deg are only used with layout: custom");
    return;
  }
  RELIT_REQUIRE(!elevation_deg.empty() && elevation_deg.size() == azimuth_deg.size(),
                "layout custom needs elevation_deg and azimuth_deg of equal, "
                "non-zero length (got ", elevation_deg.size(), " and ", azimuth_deg.size(), ")");
  RELIT_REQUIRE(static_cast<int>(elevation_deg.size()) <= PartitionLayout::kMaxVertices,
                "at most ", PartitionLayout::kMaxVertices, " vertices");
  for (double e : elevation_deg) {
    RELIT_REQUIRE(e >= -90.0 && e <= 90.0, "elevation_deg must be in [-90, 90], got ", e);
  }
}

PartitionLayout PartitionLayout::FromOptions(const PartitionLayoutOptions& options) {
  CheckOptions(options, "partitions");
  if (options.layout == "single") return Single();
  if (options.layout == "dnl13") return Dnl13();
  std::vector<Eigen::Vector3d> vertices;
  for (size_t i = 0; i < options.elevation_deg.size(); ++i) {
    vertices.push_back(DirectionFromElevationAzimuthDeg(options.elevation_deg[i], options.azimuth_deg[i]));
  }
  return FromVertices(vertices);
}

PartitionLayout PartitionLayout::Dnl13() {
  std::vector<Eigen::Vector3d> vertices = {Eigen::Vector3d::UnitZ()};
  for (int i = 0; i < 6; ++i) vertices.push_back(DirectionFromElevationAzimuthDeg(30.0, 60.0 * i));
  for (int i = 0; i < 6; ++i) vertices.push_back(DirectionFromElevationAzimuthDeg(0.0, 30.0 + 60.0 * i));
  return FromVertices(vertices);
}

PartitionLayout PartitionLayout::Single() { return FromVertices({Eigen::Vector3d::UnitZ()}); }

PartitionLayout PartitionLayout::FromVertices(std::vector<Eigen::Vector3d> vertices) {
  RELIT_REQUIRE(!vertices.empty(), "partition layout: no vertices");
  RELIT_REQUIRE(static_cast<int>(vertices.size()) <= kMaxVertices,
                "partition layout: at most ", kMaxVertices, " vertices, got ", vertices.size());
  for (auto& v : vertices) {
    RELIT_REQUIRE(v.allFinite() && v.norm() > 1e-12, "partition layout: zero or non-finite vertex");
    v.normalize();
  }
  for (size_t a = 0; a < vertices.size(); ++a) {
    for (size_t b = a + 1; b < vertices.size(); ++b) {
      const double angle = std::atan2(vertices[a].cross(vertices[b]).norm(), vertices[a].dot(vertices[b]));
      RELIT_REQUIRE(angle >= kMinSeparationRad, "partition layout: vertices ", a, " and ", b,
                    " are less than 0.5 deg apart");
    }
  }
  PartitionLayout layout;
  layout.vertices_ = vertices;
  if (vertices.size() == 1) return layout;  // one partition, no triangles

  // Hull of the vertices plus the virtual nadir (unless a vertex is there).
  const Eigen::Vector3d nadir(0, 0, -1);
  std::vector<Eigen::Vector3d> points = vertices;
  bool has_nadir = true;
  for (const auto& v : vertices) {
    if (std::acos(std::clamp(v.dot(nadir), -1.0, 1.0)) < kMinSeparationRad) has_nadir = false;
  }
  const int nadir_index = static_cast<int>(points.size());
  if (has_nadir) points.push_back(nadir);
  const std::vector<HullFace> hull = SphereHull(points);
  RELIT_REQUIRE(!hull.empty(), "partition layout: could not triangulate the vertices");

  std::vector<Face> nadir_faces;
  for (const HullFace& h : hull) {
    Face face;
    Eigen::Matrix3d columns;
    for (int c = 0; c < 3; ++c) {
      columns.col(c) = points[h.vertex[c]];
      face.vertex[c] = h.vertex[c] == nadir_index && has_nadir ? kNadir : h.vertex[c];
    }
    face.inverse = columns.inverse();
    const bool touches_nadir = std::count(face.vertex.begin(), face.vertex.end(), kNadir) > 0;
    if (touches_nadir) {
      nadir_faces.push_back(face);
    } else {
      face.triangle = static_cast<int>(layout.triangles_.size());
      layout.triangles_.push_back(face.vertex);
      layout.faces_.push_back(face);
    }
  }
  // A nadir face's real edge borders at most one real triangle: the one a
  // direction clamped onto that edge belongs to.
  for (Face& face : nadir_faces) {
    std::vector<int> edge;
    for (int v : face.vertex) {
      if (v != kNadir) edge.push_back(v);
    }
    for (size_t t = 0; t < layout.triangles_.size(); ++t) {
      const auto& tri = layout.triangles_[t];
      if (std::count(tri.begin(), tri.end(), edge[0]) && std::count(tri.begin(), tri.end(), edge[1])) {
        face.triangle = static_cast<int>(t);
      }
    }
    layout.faces_.push_back(face);
  }
  return layout;
}

const PartitionLayout::Face& PartitionLayout::Locate(const Eigen::Vector3d& direction,
                                                     Eigen::Vector3d* coords) const {
  RELIT_CHECK(!faces_.empty());
  const Face* best = nullptr;
  double best_score = -1e300;
  for (const Face& face : faces_) {
    const Eigen::Vector3d w = face.inverse * direction;
    const double score = w.minCoeff() / w.cwiseAbs().sum();
    if (score > best_score) {
      best_score = score;
      best = &face;
      *coords = w;
    }
    if (score >= 0) break;  // inside this cone (cones only overlap on edges)
  }
  return *best;
}

PartitionBlend PartitionLayout::Blend(const Eigen::Vector3d& direction_in) const {
  RELIT_REQUIRE(direction_in.allFinite() && direction_in.norm() > 0,
                "partition blend: zero or non-finite view direction");
  PartitionBlend blend;
  if (faces_.empty()) {
    blend.count = 1;
    blend.partition[0] = 0;
    blend.weight[0] = 1.0;
    return blend;
  }
  const Eigen::Vector3d direction = direction_in.normalized();
  Eigen::Vector3d w;
  const Face& face = Locate(direction, &w);
  double sum = 0;
  for (int c = 0; c < 3; ++c) {
    if (face.vertex[c] == kNadir) continue;  // dropped: clamps onto the real edge
    blend.partition[blend.count] = face.vertex[c];
    blend.weight[blend.count] = std::max(0.0, w[c]);
    sum += blend.weight[blend.count];
    ++blend.count;
  }
  for (int c = 0; c < blend.count; ++c) {
    // Only exactly at the nadir is the sum zero: split evenly there.
    blend.weight[c] = sum > 1e-300 ? blend.weight[c] / sum : 1.0 / blend.count;
  }
  return blend;
}

std::vector<int> PartitionLayout::PartitionsOf(const Eigen::Vector3d& direction) const {
  RELIT_REQUIRE(direction.allFinite() && direction.norm() > 0,
                "partition assignment: zero or non-finite view direction");
  if (faces_.empty()) return {0};
  Eigen::Vector3d w;
  const Face& face = Locate(direction.normalized(), &w);
  if (face.triangle >= 0) {
    const auto& tri = triangles_[face.triangle];
    return {tri.begin(), tri.end()};
  }
  std::vector<int> result;
  for (int v : face.vertex) {
    if (v != kNadir) result.push_back(v);
  }
  return result;
}

std::vector<std::vector<int>> PartitionLayout::AssignFrames(
    const std::vector<Eigen::Vector3d>& directions) const {
  std::vector<std::vector<int>> frames(vertices_.size());
  for (size_t f = 0; f < directions.size(); ++f) {
    for (int p : PartitionsOf(directions[f])) frames[p].push_back(static_cast<int>(f));
  }
  return frames;
}

nlohmann::json PartitionLayout::ToJson() const {
  nlohmann::json vertices = nlohmann::json::array(), elevation = nlohmann::json::array(),
                 azimuth = nlohmann::json::array(), triangles = nlohmann::json::array();
  for (const auto& v : vertices_) {
    vertices.push_back({v.x(), v.y(), v.z()});
    elevation.push_back(std::asin(std::clamp(v.z(), -1.0, 1.0)) / kDegToRad);
    azimuth.push_back(std::atan2(v.y(), v.x()) / kDegToRad);
  }
  for (const auto& t : triangles_) triangles.push_back({t[0], t[1], t[2]});
  return {{"vertices", vertices}, {"elevation_deg", elevation}, {"azimuth_deg", azimuth},
          {"triangles", triangles}};
}

}  // namespace relit::relight
