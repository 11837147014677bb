#include "reconstruct/visibility_refine.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "core/median.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "reconstruct/depth_fusion.h"
#include "reconstruct/mesh_cleanup.h"

namespace relit::reconstruct {
namespace {

// What the views say about one vertex.
struct VertexEvidence {
  int free_space = 0;  // views that see a surface behind it
  int support = 0;     // views that see a surface at it
  double mean_offset_m = 0;  // along the normal, to the seen surface (support-weighted)
};

// Per view, precomputed once: the pose both ways, and the nearest depth of
// every 3x3 neighbourhood (unknown pixels ignored), so a foreground edge one
// pixel off in the depth map does not count as seeing through the object.
struct ViewData {
  const Camera* camera = nullptr;
  Rigid3 world_from_cam;
  Eigen::Vector3d centre;
  const cv::Mat* depth = nullptr;
  cv::Mat nearest_depth;
};

VertexEvidence Judge(const Eigen::Vector3d& p, const Eigen::Vector3d& normal, const std::vector<ViewData>& views,
                     const RefineOptions& options) {
  VertexEvidence e;
  double weighted_offset = 0, weight_sum = 0;
  for (const ViewData& view : views) {
    const Camera& camera = *view.camera;
    const Eigen::Vector3d p_cam = camera.cam_from_world() * p;
    cv::Point pixel;
    if (!NearestPixel(camera, p_cam, view.depth->size(), &pixel)) continue;
    // Only views in front of the surface judge it: a grazing ray passes the
    // rim of the true surface too, and would erode every silhouette.
    const double cosine = normal.dot((view.centre - p).normalized());
    if (cosine < options.min_facing_cosine) continue;
    const double z_vertex = p_cam.z();
    const float nearest = view.nearest_depth.at<float>(pixel);
    if (nearest > 0 && nearest > z_vertex * (1 + options.free_space_tolerance)) {
      ++e.free_space;
      continue;
    }
    const float z_seen = view.depth->at<float>(pixel);
    if (z_seen <= 0 || std::abs(z_seen - z_vertex) > options.support_band * z_vertex) continue;
    ++e.support;
    const Eigen::Vector3d ray = camera.PixelToCameraRay(Eigen::Vector2d(pixel.x, pixel.y));
    const Eigen::Vector3d seen = view.world_from_cam * (ray * (z_seen / ray.z()));
    // The pixel centre's ray misses p by up to half a pixel sideways: only
    // the offset along the normal counts.
    weighted_offset += cosine * (seen - p).dot(normal);
    weight_sum += cosine;
  }
  if (weight_sum > 0) e.mean_offset_m = weighted_offset / weight_sum;
  return e;
}

// One umbrella-operator step over the one-ring (half of a Taubin pass).
void SmoothStep(const std::vector<std::vector<int>>& rings, float factor, std::vector<Eigen::Vector3f>* positions) {
  const std::vector<Eigen::Vector3f> before = *positions;
  tbb::parallel_for(size_t(0), positions->size(), [&](size_t v) {
    if (rings[v].empty()) return;
    Eigen::Vector3f mean = Eigen::Vector3f::Zero();
    for (int u : rings[v]) mean += before[u];
    mean /= static_cast<float>(rings[v].size());
    (*positions)[v] = before[v] + factor * (mean - before[v]);
  });
}

// One Taubin step: shrink by lambda, then inflate by mu = -1.02 lambda (no shrinkage).
void TaubinPass(const std::vector<std::vector<int>>& rings, double lambda, std::vector<Eigen::Vector3f>* positions) {
  SmoothStep(rings, static_cast<float>(lambda), positions);
  SmoothStep(rings, static_cast<float>(-1.02 * lambda), positions);
}

}  // namespace

WeldedMesh::WeldedMesh(const render::TriangleMesh& input) : mesh(WeldEqualPositions(input, &index)) {
  original = mesh.positions;
  for (const Eigen::Vector3f& p : original) centroid += p.cast<double>() / static_cast<double>(original.size());
}

render::TriangleMesh WeldedMesh::Unweld(const render::TriangleMesh& input, double* mean_move_m,
                                        double* max_move_m) const {
  render::TriangleMesh moved = input;
  double move_sum = 0;
  *max_move_m = 0;
  for (size_t v = 0; v < original.size(); ++v) {
    const double move = (mesh.positions[v] - original[v]).cast<double>().norm();
    move_sum += move;
    *max_move_m = std::max(*max_move_m, move);
  }
  for (size_t v = 0; v < input.positions.size(); ++v) moved.positions[v] = mesh.positions[index[v]];
  *mean_move_m = original.empty() ? 0.0 : move_sum / static_cast<double>(original.size());
  if (!moved.normals.empty()) moved.ComputeVertexNormals();
  return moved;
}

double MedianPixelFootprint(const std::vector<Camera>& cameras, const Eigen::Vector3d& point) {
  std::vector<double> footprints;
  for (const Camera& camera : cameras) footprints.push_back((camera.Center() - point).norm() / camera.intrinsics().fx);
  RELIT_REQUIRE(!footprints.empty(), "refine: no cameras");
  return Median(std::move(footprints));
}

void KeepAboveFloor(double floor_z_m, std::vector<Eigen::Vector3f>* positions) {
  for (Eigen::Vector3f& p : *positions) p.z() = std::max(p.z(), static_cast<float>(floor_z_m));
}

std::vector<double> SmoothOverRings(const std::vector<double>& offsets, const std::vector<double>& weights,
                                    const std::vector<std::vector<int>>& rings, double smoothness, double anchor,
                                    int sweeps) {
  std::vector<double> x(offsets.size(), 0.0);
  for (size_t v = 0; v < x.size(); ++v) x[v] = weights[v] > 0 ? offsets[v] : 0.0;
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    for (size_t v = 0; v < x.size(); ++v) {
      double numerator = weights[v] * offsets[v], denominator = weights[v] + anchor;
      for (int u : rings[v]) {
        numerator += smoothness * x[static_cast<size_t>(u)];
        denominator += smoothness;
      }
      x[v] = numerator / denominator;
    }
  }
  return x;
}

std::vector<std::vector<int>> VertexRings(const render::TriangleMesh& mesh) {
  std::vector<std::vector<int>> rings(mesh.positions.size());
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      for (int j = 1; j < 3; ++j) rings[t[k]].push_back(t[(k + j) % 3]);
    }
  }
  for (std::vector<int>& ring : rings) {
    std::sort(ring.begin(), ring.end());
    ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
  }
  return rings;
}

// The JSON keys are the members' names.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(RefineReport, iterations, step_m, vertices, carved_vertices_first,
                                   carved_vertices_last, supported_vertices, unseen_vertices, mean_move_m,
                                   max_move_m, seconds, self_intersection_faces_replaced)

nlohmann::json RefineReport::ToJson() const { return *this; }

render::TriangleMesh RefineWithDepthMaps(const render::TriangleMesh& mesh, const DepthEvidence& evidence,
                                         const RefineOptions& options, double floor_z_m, RefineReport* report) {
  const auto start = std::chrono::steady_clock::now();
  RELIT_REQUIRE(evidence.cameras.size() == evidence.depths.size(), "refine: ", evidence.cameras.size(),
                " cameras but ", evidence.depths.size(), " depth maps");
  RELIT_REQUIRE(!mesh.triangles.empty(), "refine: the proxy has no triangles");
  // Vertices at equal positions (UV seams of a user mesh) move as one.
  WeldedMesh weld(mesh);
  render::TriangleMesh& welded = weld.mesh;
  std::vector<Eigen::Vector3f>& positions = welded.positions;
  const size_t n = positions.size();
  std::vector<ViewData> views(evidence.cameras.size());
  for (size_t k = 0; k < views.size(); ++k) {
    const Camera& camera = evidence.cameras[k];
    RELIT_REQUIRE(evidence.depths[k].type() == CV_32FC1 && evidence.depths[k].cols == camera.intrinsics().width &&
                      evidence.depths[k].rows == camera.intrinsics().height,
                  "refine: the depth map of ", k < evidence.names.size() ? evidence.names[k] : std::to_string(k),
                  " does not match its camera");
    views[k].camera = &camera;
    views[k].world_from_cam = camera.world_from_cam();
    views[k].centre = camera.Center();
    views[k].depth = &evidence.depths[k];
    views[k].nearest_depth = NearestDepth3x3(evidence.depths[k]);
  }
  RELIT_REQUIRE(!views.empty(), "refine: no depth maps");
  const double full_step =
      options.step_m > 0 ? options.step_m : 2.0 * MedianPixelFootprint(evidence.cameras, weld.centroid);

  const std::vector<std::vector<int>> rings = VertexRings(welded);

  report->step_m = full_step;
  report->vertices = static_cast<int>(n);
  std::vector<VertexEvidence> judged(n);
  Progress progress("refine proxy", options.iterations);
  for (int iteration = 0; iteration < options.iterations; ++iteration) {
    welded.ComputeVertexNormals();
    const std::vector<Eigen::Vector3f>& normals = welded.normals;
    tbb::parallel_for(size_t(0), n, [&](size_t v) {
      judged[v] = Judge(positions[v].cast<double>(), normals[v].cast<double>(), views, options);
    });
    // The step shrinks linearly to zero: noisy depths keep flagging a few
    // vertices, and a fixed step would keep eroding them.
    const double step = full_step * (1.0 - static_cast<double>(iteration) / options.iterations);
    int carved = 0, supported = 0, unseen = 0;
    for (size_t v = 0; v < n; ++v) {
      const VertexEvidence& e = judged[v];
      double move = 0;
      if (e.free_space >= options.min_free_space_views && e.free_space > e.support) {
        move = -step;
        ++carved;
      } else if (e.support > 0) {
        move = std::clamp(options.data_weight * e.mean_offset_m, -step, step);
        ++supported;
      } else {
        ++unseen;
      }
      positions[v] += static_cast<float>(move) * normals[v];
    }
    if (options.smoothing > 0) TaubinPass(rings, options.smoothing, &positions);
    KeepAboveFloor(floor_z_m, &positions);
    if (iteration == 0) report->carved_vertices_first = carved;
    report->carved_vertices_last = carved;
    report->supported_vertices = supported;
    report->unseen_vertices = unseen;
    report->iterations = iteration + 1;
    spdlog::debug("refine {}: {} vertices carved, {} supported, {} unseen", iteration, carved, supported, unseen);
    progress.Advance();
  }

  // Smoothing alone: each iteration's pull to the noisy depths undoes its own pass.
  for (int pass = 0; options.smoothing > 0 && pass < options.final_smoothing_iterations; ++pass) {
    TaubinPass(rings, options.smoothing, &positions);
    KeepAboveFloor(floor_z_m, &positions);
  }

  const render::TriangleMesh refined = weld.Unweld(mesh, &report->mean_move_m, &report->max_move_m);
  report->seconds = SecondsSince(start);
  spdlog::info("refine: {} iterations of {:.2f} mm steps; {} of {} vertices in free space at first, {} at last; "
               "vertices moved {:.2f} mm on average (max {:.2f} mm)",
               report->iterations, 1e3 * full_step, report->carved_vertices_first, n, report->carved_vertices_last,
               1e3 * report->mean_move_m, 1e3 * report->max_move_m);
  return refined;
}

}  // namespace relit::reconstruct
