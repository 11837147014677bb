#include "reconstruct/surface_photo_refine.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "core/render/scene.h"
#include "reconstruct/visibility_refine.h"

namespace relit::reconstruct {
namespace {

struct PhotoView {
  const Camera* camera = nullptr;
  Eigen::Vector3d centre;
  cv::Mat gray;  // CV_32F
};

// What the photometric search says about one vertex: an offset along the
// normal and how much to trust it (0 = no vote).
struct OffsetVote {
  double offset_m = 0;
  double weight = 0;
};

// Bilinear grey value; false outside the image.
bool SampleGray(const cv::Mat& gray, const Eigen::Vector2d& pixel, float* value) {
  const double x = pixel.x(), y = pixel.y();
  if (!(x >= 0 && y >= 0 && x < gray.cols - 1 && y < gray.rows - 1)) return false;
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const float* row0 = gray.ptr<float>(y0) + x0;
  const float* row1 = gray.ptr<float>(y0 + 1) + x0;
  *value = (1 - fy) * ((1 - fx) * row0[0] + fx * row0[1]) + fy * ((1 - fx) * row1[0] + fx * row1[1]);
  return true;
}

// Zero mean, unit norm; false for a flat patch.
bool Normalise(std::vector<float>* patch) {
  double mean = 0;
  for (float v : *patch) mean += v;
  mean /= static_cast<double>(patch->size());
  double norm = 0;
  for (float& v : *patch) {
    v -= static_cast<float>(mean);
    norm += static_cast<double>(v) * v;
  }
  if (norm < 1e-6) return false;
  const float scale = static_cast<float>(1.0 / std::sqrt(norm));
  for (float& v : *patch) v *= scale;
  return true;
}

double GreyStd(const std::vector<float>& patch) {
  double sum = 0, sum2 = 0;
  for (float v : patch) {
    sum += v;
    sum2 += static_cast<double>(v) * v;
  }
  const double n = static_cast<double>(patch.size());
  return std::sqrt(std::max(0.0, sum2 / n - (sum / n) * (sum / n)));
}

// Up to max_views views that see p from the front, unoccluded: the most
// frontal first, then spread in angle (below).
std::vector<int> VotingViews(const Eigen::Vector3d& p, const Eigen::Vector3d& normal, const std::vector<PhotoView>& views,
                             const render::Scene& scene, double lift_m, const SurfacePhotoOptions& options) {
  std::vector<std::pair<double, int>> facing;
  const Eigen::Vector3d origin = p + lift_m * normal;  // off the surface the ray starts on
  for (size_t k = 0; k < views.size(); ++k) {
    const Eigen::Vector3d to_camera = views[k].centre - origin;
    const double distance = to_camera.norm();
    const Eigen::Vector3d direction = to_camera / distance;
    const double cosine = normal.dot(direction);
    if (cosine < options.min_facing_cosine) continue;
    Eigen::Vector2d pixel;
    if (!views[k].camera->Project(p, &pixel)) continue;
    if (scene.Occluded(origin.cast<float>(), direction.cast<float>(), 0.0f, static_cast<float>(distance))) continue;
    facing.emplace_back(cosine, static_cast<int>(k));
  }
  std::sort(facing.begin(), facing.end(), std::greater<>());
  // The most frontal view, then each time the view farthest in angle from
  // those picked: neighbouring video frames see the patch from almost the
  // same point, and a sub-pixel disagreement between them says nothing about
  // depth (farthest-point sampling of the viewing directions).
  std::vector<int> picked;
  std::vector<Eigen::Vector3d> directions;
  std::vector<double> nearest_cos(facing.size(), -2.0);
  std::vector<bool> taken(facing.size(), false);
  for (size_t next = 0; !facing.empty() && static_cast<int>(picked.size()) < options.max_views;) {
    taken[next] = true;
    const int k = facing[next].second;
    picked.push_back(k);
    const Eigen::Vector3d direction = (views[static_cast<size_t>(k)].centre - origin).normalized();
    double farthest = 2.0;
    bool found = false;
    for (size_t i = 0; i < facing.size(); ++i) {
      if (taken[i]) continue;
      const Eigen::Vector3d d = (views[static_cast<size_t>(facing[i].second)].centre - origin).normalized();
      nearest_cos[i] = std::max(nearest_cos[i], d.dot(direction));
      if (nearest_cos[i] < farthest) {
        farthest = nearest_cos[i];
        next = i;
        found = true;
      }
    }
    if (!found) break;
  }
  return picked;
}

// Photo-consistency of normalised patches (one per view): each view's mean
// ZNCC to the others, the better half of the views averaged (a view that
// sees a shadow edge or an occluder there does not vote).
double PatchAgreement(const std::vector<std::vector<float>>& patches) {
  const size_t n = patches.size();
  std::vector<double> mean_ncc(n, 0.0);
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) {
      double dot = 0;
      for (size_t s = 0; s < patches[i].size(); ++s) dot += patches[i][s] * patches[j][s];
      mean_ncc[i] += dot;
      mean_ncc[j] += dot;
    }
  }
  for (double& m : mean_ncc) m /= static_cast<double>(n - 1);
  std::sort(mean_ncc.begin(), mean_ncc.end(), std::greater<>());
  const size_t half = (n + 1) / 2;
  double sum = 0;
  for (size_t i = 0; i < half; ++i) sum += mean_ncc[i];
  return sum / static_cast<double>(half);
}

// The surface around a vertex as a height over its tangent plane,
// h(u, v) = c0 u^2 + c1 u v + c2 v^2 + c3 u + c4 v along the normal (u, v
// along t1, t2). A flat patch on a convex surface stands out of it by
// rho^2 / 2R at distance rho: on the cow (R ~ 25 mm, 9x9 samples a
// millimetre apart) that pulled every vote ~0.3 mm inwards.
struct LocalSurface {
  Eigen::Vector3d t1, t2;
  Eigen::Matrix<double, 5, 1> height = Eigen::Matrix<double, 5, 1>::Zero();
  Eigen::Vector3d Point(const Eigen::Vector3d& p, const Eigen::Vector3d& normal, double u, double v) const {
    const double h = height[0] * u * u + height[1] * u * v + height[2] * v * v + height[3] * u + height[4] * v;
    return p + u * t1 + v * t2 + h * normal;
  }
};

// Each vertex's one- and two-ring neighbours (the topology does not change
// between rounds).
std::vector<std::vector<int>> TwoRings(const std::vector<std::vector<int>>& rings) {
  std::vector<std::vector<int>> two_rings(rings.size());
  for (size_t v = 0; v < rings.size(); ++v) {
    std::vector<int>& neighbourhood = two_rings[v];
    for (int u : rings[v]) {
      neighbourhood.push_back(u);
      for (int w : rings[static_cast<size_t>(u)]) {
        if (static_cast<size_t>(w) != v) neighbourhood.push_back(w);
      }
    }
    std::sort(neighbourhood.begin(), neighbourhood.end());
    neighbourhood.erase(std::unique(neighbourhood.begin(), neighbourhood.end()), neighbourhood.end());
  }
  return two_rings;
}

// Least-squares height field through the vertex's two-ring (flat without
// `two_ring`, or when it is too small to fit).
LocalSurface FitLocalSurface(size_t vertex, const Eigen::Vector3d& normal, const std::vector<Eigen::Vector3f>& positions,
                             const std::vector<int>* two_ring) {
  LocalSurface surface;
  surface.t1 = normal.unitOrthogonal();
  surface.t2 = normal.cross(surface.t1);
  if (two_ring == nullptr || two_ring->size() < 8) return surface;
  const Eigen::Vector3d p = positions[vertex].cast<double>();
  Eigen::Matrix<double, 5, 5> normal_matrix = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix<double, 5, 1> rhs = Eigen::Matrix<double, 5, 1>::Zero();
  for (int w : *two_ring) {
    const Eigen::Vector3d d = positions[static_cast<size_t>(w)].cast<double>() - p;
    const double u = d.dot(surface.t1), v = d.dot(surface.t2);
    Eigen::Matrix<double, 5, 1> row;
    row << u * u, u * v, v * v, u, v;
    normal_matrix += row * row.transpose();
    rhs += row * d.dot(normal);
  }
  const Eigen::Matrix<double, 5, 1> height = normal_matrix.ldlt().solve(rhs);
  if (height.allFinite()) surface.height = height;
  return surface;
}

// Sweeps offsets in [-search_m, search_m] along the normal.
OffsetVote SearchVertex(const Eigen::Vector3d& p, const Eigen::Vector3d& normal, const LocalSurface& surface,
                        const std::vector<PhotoView>& views, const render::Scene& scene, double spacing_m,
                        double search_m, const SurfacePhotoOptions& options) {
  const std::vector<int> voters = VotingViews(p, normal, views, scene, spacing_m, options);
  if (voters.size() < 2) return {};
  const int r = options.patch_radius, steps = options.steps;
  const size_t samples = static_cast<size_t>((2 * r + 1) * (2 * r + 1));
  const double step_m = search_m / steps;
  std::vector<double> scores(static_cast<size_t>(2 * steps + 1), -1.0);
  std::vector<std::vector<float>> patches(voters.size(), std::vector<float>(samples));
  for (int h = -steps; h <= steps; ++h) {
    const Eigen::Vector3d centre = p + (h * step_m) * normal;
    std::vector<std::vector<float>> usable;
    for (size_t v = 0; v < voters.size(); ++v) {
      const PhotoView& view = views[static_cast<size_t>(voters[v])];
      bool inside = true;
      size_t s = 0;
      for (int b = -r; b <= r && inside; ++b) {
        for (int a = -r; a <= r && inside; ++a, ++s) {
          Eigen::Vector2d pixel;
          inside = view.camera->Project(surface.Point(centre, normal, a * spacing_m, b * spacing_m), &pixel) &&
                   SampleGray(view.gray, pixel, &patches[v][s]);
        }
      }
      if (!inside) continue;
      // The most frontal view's patch at the current surface must show texture.
      if (h == 0 && v == 0 && GreyStd(patches[v]) < options.min_texture) return {};
      std::vector<float> patch = patches[v];
      if (Normalise(&patch)) usable.push_back(std::move(patch));
    }
    if (usable.size() >= 2) scores[static_cast<size_t>(h + steps)] = PatchAgreement(usable);
  }
  const size_t best = static_cast<size_t>(std::max_element(scores.begin(), scores.end()) - scores.begin());
  // An optimum at the edge of the search is not an optimum.
  if (best == 0 || best + 1 == scores.size() || scores[best] < options.min_score) return {};
  const double before = scores[best - 1], peak = scores[best], after = scores[best + 1];
  const double curvature = before - 2 * peak + after;
  const double sub_step = curvature < 0 ? std::clamp(0.5 * (before - after) / curvature, -0.5, 0.5) : 0.0;
  OffsetVote vote;
  vote.offset_m = (static_cast<double>(best) - steps + sub_step) * step_m;
  vote.weight = peak;
  return vote;
}

}  // namespace

// The JSON keys are the members' names.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(SurfacePhotoReport, rounds, vertices, measured_vertices_first,
                                   measured_vertices_last, search_m, patch_spacing_m, mean_move_m, max_move_m,
                                   seconds, self_intersection_faces_replaced)

nlohmann::json SurfacePhotoReport::ToJson() const { return *this; }

render::TriangleMesh RefineSurfacePhotometric(const render::TriangleMesh& mesh, const std::vector<Camera>& cameras,
                                              const std::vector<cv::Mat>& grays, const SurfacePhotoOptions& options,
                                              double floor_z_m, SurfacePhotoReport* report) {
  const auto start = std::chrono::steady_clock::now();
  RELIT_REQUIRE(cameras.size() == grays.size(), "refine.photometric: ", cameras.size(), " cameras but ",
                grays.size(), " frames");
  RELIT_REQUIRE(!mesh.triangles.empty(), "refine.photometric: the proxy has no triangles");
  WeldedMesh weld(mesh);  // UV seams move as one
  render::TriangleMesh& welded = weld.mesh;
  std::vector<Eigen::Vector3f>& positions = welded.positions;
  const size_t n = positions.size();

  std::vector<PhotoView> views(cameras.size());
  for (size_t k = 0; k < views.size(); ++k) {
    const Intrinsics& intrinsics = cameras[k].intrinsics();
    RELIT_REQUIRE(grays[k].type() == CV_8UC1 && grays[k].cols == intrinsics.width && grays[k].rows == intrinsics.height,
                  "refine.photometric: frame ", k, " does not match its camera (", intrinsics.width, "x",
                  intrinsics.height, " grey expected)");
    views[k].camera = &cameras[k];
    views[k].centre = cameras[k].Center();
    grays[k].convertTo(views[k].gray, CV_32F);
  }
  RELIT_REQUIRE(!views.empty(), "refine.photometric: no frames");
  const double spacing_m = MedianPixelFootprint(cameras, weld.centroid);
  const std::vector<std::vector<int>> rings = VertexRings(welded);
  const std::vector<std::vector<int>> two_rings = options.curved_patch ? TwoRings(rings) : std::vector<std::vector<int>>{};
  report->vertices = static_cast<int>(n);
  report->search_m = options.search_px * spacing_m;
  report->patch_spacing_m = spacing_m;

  Progress progress("surface photometric refine", options.rounds);
  std::vector<OffsetVote> votes(n);
  for (int round = 0; round < options.rounds; ++round) {
    const double search_m = report->search_m / std::pow(2.0, round);
    welded.ComputeVertexNormals();
    render::Scene scene;  // occlusion by the current surface
    scene.AddObject(welded, render::Material::Lambert(render::Rgb(0.5f, 0.5f, 0.5f)), 0);
    scene.Commit();
    tbb::parallel_for(size_t(0), n, [&](size_t v) {
      const Eigen::Vector3d normal = welded.normals[v].cast<double>().normalized();
      const LocalSurface surface =
          FitLocalSurface(v, normal, positions, options.curved_patch ? &two_rings[v] : nullptr);
      votes[v] = SearchVertex(positions[v].cast<double>(), normal, surface, views, scene, spacing_m, search_m, options);
    });
    const int measured = static_cast<int>(std::count_if(votes.begin(), votes.end(), [](const OffsetVote& o) {
      return o.weight > 0;
    }));
    std::vector<double> voted(n), weights(n);
    for (size_t v = 0; v < n; ++v) {
      voted[v] = votes[v].offset_m;
      weights[v] = votes[v].weight;
    }
    // A sure vertex weighs ~1; a faint pull to 0 keeps unmeasured regions.
    const std::vector<double> offsets = SmoothOverRings(voted, weights, rings, options.smoothness, 1e-3, 200);
    for (size_t v = 0; v < n; ++v) {
      positions[v] += static_cast<float>(std::clamp(offsets[v], -search_m, search_m)) * welded.normals[v].normalized();
    }
    KeepAboveFloor(floor_z_m, &positions);
    if (round == 0) report->measured_vertices_first = measured;
    report->measured_vertices_last = measured;
    report->rounds = round + 1;
    spdlog::debug("surface photometric refine {}: {} of {} vertices measured within +/- {:.2f} mm", round, measured, n,
                  1e3 * search_m);
    progress.Advance();
  }

  const render::TriangleMesh refined = weld.Unweld(mesh, &report->mean_move_m, &report->max_move_m);
  report->seconds = SecondsSince(start);
  spdlog::info("surface photometric refine: {} rounds from +/- {:.2f} mm; {} of {} vertices measured at first, {} at last; "
               "vertices moved {:.2f} mm on average (max {:.2f} mm)",
               report->rounds, 1e3 * report->search_m, report->measured_vertices_first, n,
               report->measured_vertices_last, 1e3 * report->mean_move_m, 1e3 * report->max_move_m);
  return refined;
}

}  // namespace relit::reconstruct
