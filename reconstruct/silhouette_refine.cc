#include "reconstruct/silhouette_refine.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <utility>

#include <Eigen/QR>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "reconstruct/visibility_refine.h"

namespace relit::reconstruct {
namespace {

constexpr double kProfileStepPx = 0.5;   // sample spacing along a profile
constexpr double kProfileHalfPx = 5.0;   // profile reaches +/- this from the proxy's outline
constexpr int kSupersampling = 4;        // coverage rasterised at 4 x 4 samples per pixel
constexpr double kRimSearchPx = 2.0;     // a contour point's rim vertex projects within this
constexpr double kMinNormalShift = 0.3;  // the rim's normal must move the outline >= 0.3 px per footprint

// The design matrix of a step at s: the object's appearance near its outline
// is a linear ramp, the board's its print x gain + offset; a is the object's
// coverage of sample t (box pixel: the step crosses the sample's pixel
// linearly).
Eigen::Matrix<double, Eigen::Dynamic, 4> StepDesign(const std::vector<double>& t, const std::vector<float>& albedo,
                                                    double s) {
  Eigen::Matrix<double, Eigen::Dynamic, 4> design(static_cast<Eigen::Index>(t.size()), 4);
  for (size_t i = 0; i < t.size(); ++i) {
    const double a = std::clamp(0.5 + s - t[i], 0.0, 1.0);
    const auto row = static_cast<Eigen::Index>(i);
    design(row, 0) = a;
    design(row, 1) = a * t[i];
    design(row, 2) = (1 - a) * albedo[i];
    design(row, 3) = 1 - a;
  }
  return design;
}

// Sub-pixel contour of the binary coverage: point, outward unit normal.
struct ContourPoint {
  Eigen::Vector2d pixel;
  Eigen::Vector2d outward;
};

float SampleBilinear(const cv::Mat& image, double x, double y, int channel) {
  const int x0 = std::clamp(static_cast<int>(std::floor(x)), 0, image.cols - 2);
  const int y0 = std::clamp(static_cast<int>(std::floor(y)), 0, image.rows - 2);
  const float fx = static_cast<float>(std::clamp(x - x0, 0.0, 1.0)), fy = static_cast<float>(std::clamp(y - y0, 0.0, 1.0));
  const int c = image.channels();
  const float* r0 = image.ptr<float>(y0) + x0 * c + channel;
  const float* r1 = image.ptr<float>(y0 + 1) + x0 * c + channel;
  return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[c]) + fy * ((1 - fx) * r1[0] + fx * r1[c]);
}

// The proxy's coverage of every pixel (area fraction, CV_32F) from its
// projected triangles, rasterised at kSupersampling^2 samples per pixel.
cv::Mat ProjectedCoverage(const render::TriangleMesh& mesh, const std::vector<Eigen::Vector2d>& projected,
                          const std::vector<char>& in_front, int width, int height) {
  cv::Mat fine(height * kSupersampling, width * kSupersampling, CV_8U, cv::Scalar(0));
  constexpr int kShift = 4;  // fixed-point bits of fillConvexPoly
  for (const auto& triangle : mesh.triangles) {
    std::array<cv::Point, 3> corners;
    bool usable = true;
    for (int k = 0; k < 3; ++k) {
      const auto v = static_cast<size_t>(triangle[k]);
      usable = usable && in_front[v];
      // Pixel centres at integers: fine sample centre X maps to (X + 0.5) / s - 0.5.
      const Eigen::Vector2d fine_pixel = (projected[v].array() + 0.5) * kSupersampling - 0.5;
      corners[static_cast<size_t>(k)] = cv::Point(static_cast<int>(std::lround(fine_pixel.x() * (1 << kShift))),
                                                  static_cast<int>(std::lround(fine_pixel.y() * (1 << kShift))));
    }
    if (usable) cv::fillConvexPoly(fine, corners.data(), 3, cv::Scalar(1), cv::LINE_8, kShift);
  }
  cv::Mat fine_float, coverage;
  fine.convertTo(fine_float, CV_32F);
  cv::resize(fine_float, coverage, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  return coverage;
}

// The outer contours of the coverage, with normals pointing out of it.
std::vector<ContourPoint> OuterContour(const cv::Mat& coverage) {
  cv::Mat inside = coverage > 0.5f;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(inside, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  std::vector<ContourPoint> points;
  constexpr int kTangentSpan = 3;
  for (const auto& contour : contours) {
    const int n = static_cast<int>(contour.size());
    if (n < 4 * kTangentSpan) continue;
    for (int i = 0; i < n; ++i) {
      const cv::Point& a = contour[static_cast<size_t>((i + kTangentSpan) % n)];
      const cv::Point& b = contour[static_cast<size_t>((i - kTangentSpan + n) % n)];
      Eigen::Vector2d tangent(a.x - b.x, a.y - b.y);
      if (tangent.norm() < 1e-9) continue;
      tangent.normalize();
      ContourPoint point;
      point.pixel = Eigen::Vector2d(contour[static_cast<size_t>(i)].x, contour[static_cast<size_t>(i)].y);
      point.outward = Eigen::Vector2d(tangent.y(), -tangent.x());
      const Eigen::Vector2d ahead = point.pixel + 2 * point.outward, behind = point.pixel - 2 * point.outward;
      if (SampleBilinear(coverage, ahead.x(), ahead.y(), 0) > SampleBilinear(coverage, behind.x(), behind.y(), 0)) {
        point.outward = -point.outward;
      }
      points.push_back(point);
    }
  }
  return points;
}

// Rim vertices bucketed by the pixel they project to.
class RimIndex {
 public:
  RimIndex(const std::vector<Eigen::Vector2d>& projected, const std::vector<char>& rim, int width)
      : projected_(projected), width_(width) {
    for (size_t v = 0; v < rim.size(); ++v) {
      if (rim[v]) buckets_[Key(projected[v])].push_back(static_cast<int>(v));
    }
  }
  // The rim vertex projecting nearest to `pixel` within kRimSearchPx; -1 if none.
  int Nearest(const Eigen::Vector2d& pixel) const {
    int best = -1;
    double best_distance = kRimSearchPx;
    const int reach = static_cast<int>(std::ceil(kRimSearchPx));
    const int x = static_cast<int>(std::lround(pixel.x())), y = static_cast<int>(std::lround(pixel.y()));
    for (int dy = -reach; dy <= reach; ++dy) {
      for (int dx = -reach; dx <= reach; ++dx) {
        const auto found = buckets_.find(static_cast<int64_t>(y + dy) * width_ + (x + dx));
        if (found == buckets_.end()) continue;
        for (int v : found->second) {
          const double distance = (projected_[static_cast<size_t>(v)] - pixel).norm();
          if (distance <= best_distance) {
            best_distance = distance;
            best = v;
          }
        }
      }
    }
    return best;
  }

 private:
  int64_t Key(const Eigen::Vector2d& p) const {
    return static_cast<int64_t>(std::lround(p.y())) * width_ + std::lround(p.x());
  }
  const std::vector<Eigen::Vector2d>& projected_;
  int width_;
  std::unordered_map<int64_t, std::vector<int>> buckets_;
};

struct Vote {
  int vertex;
  float offset_m;
};

struct FrameVotes {
  std::vector<Vote> votes;
  int64_t profiles = 0;
};

// Every vertex projected into the frame; the rim: vertices whose normal is
// nearly across the view.
struct ProjectedMesh {
  std::vector<Eigen::Vector2d> pixels;
  std::vector<char> in_front, rim;
};

ProjectedMesh ProjectMesh(const render::TriangleMesh& mesh, const Camera& camera, double rim_cosine) {
  const size_t n = mesh.positions.size();
  ProjectedMesh projected{std::vector<Eigen::Vector2d>(n, Eigen::Vector2d::Zero()), std::vector<char>(n, 0),
                          std::vector<char>(n, 0)};
  const Eigen::Vector3d centre = camera.Center();
  for (size_t v = 0; v < n; ++v) {
    const Eigen::Vector3d p = mesh.positions[v].cast<double>();
    projected.in_front[v] = camera.Project(p, &projected.pixels[v]);
    const Eigen::Vector3d to_camera = (centre - p).normalized();
    projected.rim[v] = projected.in_front[v] &&
                       std::abs(mesh.normals[v].cast<double>().normalized().dot(to_camera)) < rim_cosine;
  }
  return projected;
}

// One profile across the proxy's outline: the frame's colours, the board
// print's albedo where each sample's ray meets the board plane, and where
// the proxy's own outline lies on it (measured as the fit measures the
// object's: the coverage summed).
struct Profile {
  std::vector<Eigen::Vector3f> colours;
  std::vector<float> albedo;
  double proxy_offset_px = 0;
};

// False where the profile leaves the image or a ray misses the board plane.
bool SampleProfile(const ContourPoint& point, const Camera& camera, const cv::Mat& colour, const cv::Mat& coverage,
                   const BoardPrint& board, Profile* profile) {
  const int half = static_cast<int>(std::lround(kProfileHalfPx / kProfileStepPx));
  const Eigen::Vector2d first = point.pixel - half * kProfileStepPx * point.outward;
  const Eigen::Vector2d last = point.pixel + half * kProfileStepPx * point.outward;
  if (std::min({first.x(), last.x(), first.y(), last.y()}) < 1 || std::max(first.x(), last.x()) > colour.cols - 2 ||
      std::max(first.y(), last.y()) > colour.rows - 2) {
    return false;
  }
  const Eigen::Vector3d centre = camera.Center();
  profile->colours.resize(static_cast<size_t>(2 * half + 1));
  profile->albedo.resize(profile->colours.size());
  double covered = 0;
  for (int i = -half; i <= half; ++i) {
    const Eigen::Vector2d pixel = point.pixel + i * kProfileStepPx * point.outward;
    const Eigen::Vector3d ray = camera.PixelToWorldRay(pixel);
    if (ray.z() > -1e-6) return false;  // towards the sky
    const auto k = static_cast<size_t>(i + half);
    profile->albedo[k] = board.Albedo(centre + (-centre.z() / ray.z()) * ray);
    for (int c = 0; c < 3; ++c) profile->colours[k][c] = SampleBilinear(colour, pixel.x(), pixel.y(), c);
    covered += SampleBilinear(coverage, pixel.x(), pixel.y(), 0);
  }
  // A step at s covers (s + half step) / step + half samples (box pixels).
  profile->proxy_offset_px = kProfileStepPx * covered - (half + 0.5) * kProfileStepPx;
  return true;
}

// The move of rim vertex v along its normal that puts the proxy's outline
// on the fitted one; false for a profile of a kind that does not vote
// (header) or a vertex whose move would hardly shift the outline.
bool RimVote(const render::TriangleMesh& mesh, const ProjectedMesh& projected, size_t v, const Camera& camera,
             const Eigen::Vector3d& flash_m, const ContourPoint& point, const Profile& profile, const OutlineFit& fit,
             const SilhouetteOptions& options, float* offset_m) {
  const Eigen::Vector3d p = mesh.positions[v].cast<double>();
  const Eigen::Vector3d normal = mesh.normals[v].cast<double>().normalized();
  const double light_cosine = normal.dot((flash_m - p).normalized());
  const bool lit_and_bright = fit.polarity > 0 && light_cosine >= options.lit_cosine;
  const bool shadowed_and_dark = fit.polarity < 0 && light_cosine < options.shadow_cosine;
  if (!lit_and_bright && !shadowed_and_dark) return false;
  constexpr double kEpsilonM = 1e-4;  // the outline's shift per metre along the normal, by a finite difference
  Eigen::Vector2d moved;
  if (!camera.Project(p + kEpsilonM * normal, &moved)) return false;
  const double shift_px_per_m = (moved - projected.pixels[v]).dot(point.outward) / kEpsilonM;
  const double depth_m = (camera.cam_from_world() * p).z();
  if (shift_px_per_m < kMinNormalShift * camera.intrinsics().fx / depth_m) return false;
  *offset_m = static_cast<float>((fit.offset_px - profile.proxy_offset_px) / shift_px_per_m);
  return true;
}

// One frame's votes: for each point of the proxy's outer outline that a rim
// vertex forms, the move that puts the outline on the object's.
FrameVotes VoteInFrame(const render::TriangleMesh& mesh, const SilhouetteView& view, const BoardPrint& board,
                       const SilhouetteOptions& options) {
  const Camera& camera = view.camera;
  const int width = camera.intrinsics().width, height = camera.intrinsics().height;
  const ProjectedMesh projected = ProjectMesh(mesh, camera, options.rim_cosine);
  FrameVotes result;
  const cv::Mat coverage = ProjectedCoverage(mesh, projected.pixels, projected.in_front, width, height);
  const std::vector<ContourPoint> contour = OuterContour(coverage);
  if (contour.empty()) return result;
  const RimIndex rim_index(projected.pixels, projected.rim, width);
  const Image image = view.load_image();
  RELIT_REQUIRE(image.width() == width && image.height() == height && image.channels() >= 3,
                "refine.silhouette: a frame is ", image.width(), "x", image.height(), "x", image.channels(),
                ", its camera ", width, "x", height, "x3");
  const cv::Mat colour(height, width, CV_32FC(image.channels()), const_cast<float*>(image.data().data()));
  Profile profile;
  for (const ContourPoint& point : contour) {
    const int vertex = rim_index.Nearest(point.pixel);
    if (vertex < 0 || !SampleProfile(point, camera, colour, coverage, board, &profile)) continue;
    ++result.profiles;
    const OutlineFit fit = FitOutline(profile.colours, profile.albedo, kProfileStepPx, options.search_px);
    if (!fit.found || fit.contrast < options.min_contrast) continue;
    float offset_m = 0;
    if (RimVote(mesh, projected, static_cast<size_t>(vertex), camera, view.flash_m, point, profile, fit, options,
                &offset_m)) {
      result.votes.push_back({vertex, offset_m});
    }
  }
  return result;
}

}  // namespace

OutlineFit FitOutline(const std::vector<Eigen::Vector3f>& colours, const std::vector<float>& board_albedo,
                      double step_px, double search_px) {
  RELIT_REQUIRE(colours.size() == board_albedo.size() && colours.size() >= 7, "FitOutline: ", colours.size(),
                " colours, ", board_albedo.size(), " albedos (>= 7 each)");
  const size_t n = colours.size();
  std::vector<double> t(n);
  for (size_t i = 0; i < n; ++i) t[i] = (static_cast<double>(i) - 0.5 * static_cast<double>(n - 1)) * step_px;
  Eigen::MatrixXd observed(static_cast<Eigen::Index>(n), 3);
  for (size_t i = 0; i < n; ++i) observed.row(static_cast<Eigen::Index>(i)) = colours[i].cast<double>().transpose();
  // Candidate steps a quarter pixel apart, inside the profile.
  const double reach = std::min(search_px, t.back() - 1.0);
  double best_cost = std::numeric_limits<double>::infinity(), best_step = 0;
  Eigen::MatrixXd solution;  // of the best step
  for (double s = -reach; s <= reach + 1e-9; s += 0.25) {
    const Eigen::Matrix<double, Eigen::Dynamic, 4> design = StepDesign(t, board_albedo, s);
    Eigen::MatrixXd candidate = design.colPivHouseholderQr().solve(observed);
    const double cost = (design * candidate - observed).squaredNorm();
    if (cost < best_cost) {
      best_cost = cost;
      best_step = s;
      solution = std::move(candidate);
    }
  }
  OutlineFit fit;
  if (!std::isfinite(best_cost) || std::abs(best_step) > reach - 0.01) return fit;  // at the search's edge
  // Board albedo at the step (linear between samples).
  const double position = best_step / step_px + 0.5 * static_cast<double>(n - 1);
  const size_t below = std::min(static_cast<size_t>(std::floor(position)), n - 2);
  const double fraction = position - static_cast<double>(below);
  const double albedo = (1 - fraction) * board_albedo[below] + fraction * board_albedo[below + 1];
  double contrast2 = 0;
  for (int c = 0; c < 3; ++c) {
    const double object = solution(0, c) + solution(1, c) * best_step;
    const double board = solution(2, c) * albedo + solution(3, c);
    contrast2 += (object - board) * (object - board);
    fit.polarity += object - board;
  }
  const double residual_rms = std::sqrt(best_cost / static_cast<double>(n) + 1e-12);
  fit.found = true;
  fit.offset_px = best_step;
  fit.contrast = std::sqrt(contrast2) / residual_rms;
  return fit;
}

BoardPrint::BoardPrint(const BoardSpec& spec, double texel_m) : spec_(spec), texel_m_(texel_m) {
  const cv::Mat print = DrawBoardImage(spec, 1.0 / texel_m, 0);
  print.convertTo(print_, CV_32F, 1.0 / 255.0);
}

float BoardPrint::Albedo(const Eigen::Vector3d& world_point) const {
  // World: centred, y up the print; the print's rows run down it. OpenCV
  // draws a square's edge through texel centres (texel i's centre lies i
  // texels from the print's edge): so the corners land where its detector
  // finds them (BoardPrintTest).
  const double column = (world_point.x() + 0.5 * spec_.width_m()) / texel_m_;
  const double row = (0.5 * spec_.height_m() - world_point.y()) / texel_m_;
  if (column < 0 || row < 0 || column > print_.cols - 1 || row > print_.rows - 1) return 1.0f;
  return SampleBilinear(print_, column, row, 0);
}

// The JSON keys are the members' names.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(SilhouetteReport, rounds, views, vertices, voting_vertices_first,
                                   voting_vertices_last, votes_first, profiles_first, mean_move_m, max_move_m, seconds,
                                   self_intersection_faces_replaced)

nlohmann::json SilhouetteReport::ToJson() const { return *this; }

render::TriangleMesh RefineSilhouettes(const render::TriangleMesh& mesh, const std::vector<SilhouetteView>& views,
                                       const BoardPrint& board, const SilhouetteOptions& options, double floor_z_m,
                                       SilhouetteReport* report) {
  const auto start = std::chrono::steady_clock::now();
  RELIT_REQUIRE(!mesh.triangles.empty(), "refine.silhouette: the proxy has no triangles");
  RELIT_REQUIRE(!views.empty(), "refine.silhouette: no frames");
  WeldedMesh weld(mesh);  // UV seams move as one
  render::TriangleMesh& welded = weld.mesh;
  const size_t n = welded.positions.size();
  const std::vector<std::vector<int>> rings = VertexRings(welded);
  report->views = static_cast<int>(views.size());
  report->vertices = static_cast<int>(n);
  std::vector<Camera> cameras;
  for (const SilhouetteView& view : views) cameras.push_back(view.camera);
  const double footprint_m = MedianPixelFootprint(cameras, weld.centroid);
  const double max_move_m = options.search_px * footprint_m;

  Progress progress("silhouette refine", static_cast<int64_t>(options.rounds) * static_cast<int64_t>(views.size()));
  for (int round = 0; round < options.rounds; ++round) {
    welded.ComputeVertexNormals();
    std::vector<FrameVotes> per_view(views.size());
    tbb::parallel_for(size_t(0), views.size(), [&](size_t k) {
      per_view[k] = VoteInFrame(welded, views[k], board, options);
      progress.Advance();
    });
    std::vector<std::vector<float>> votes(n);
    int64_t accepted = 0, profiles = 0;
    for (const FrameVotes& frame : per_view) {
      for (const Vote& vote : frame.votes) votes[static_cast<size_t>(vote.vertex)].push_back(vote.offset_m);
      accepted += static_cast<int64_t>(frame.votes.size());
      profiles += frame.profiles;
    }
    // Per vertex the median vote (a profile can still fit something else),
    // weighted by how many frames agree to have it (up to 6).
    std::vector<double> offsets(n, 0.0), weights(n, 0.0);
    int voting = 0;
    for (size_t v = 0; v < n; ++v) {
      std::vector<float>& list = votes[v];
      if (static_cast<int>(list.size()) < options.min_votes) continue;
      std::nth_element(list.begin(), list.begin() + static_cast<std::ptrdiff_t>(list.size() / 2), list.end());
      offsets[v] = list[list.size() / 2];
      weights[v] = std::min<double>(static_cast<double>(list.size()), 6.0);
      ++voting;
    }
    // The pull to 0 where no frame voted: 1/20 of one vote.
    const std::vector<double> smoothed = SmoothOverRings(offsets, weights, rings, options.smoothness, 0.05, 100);
    for (size_t v = 0; v < n; ++v) {
      welded.positions[v] +=
          static_cast<float>(std::clamp(smoothed[v], -max_move_m, max_move_m)) * welded.normals[v].normalized();
    }
    KeepAboveFloor(floor_z_m, &welded.positions);
    if (round == 0) {
      report->voting_vertices_first = voting;
      report->votes_first = accepted;
      report->profiles_first = profiles;
    }
    report->voting_vertices_last = voting;
    report->rounds = round + 1;
    spdlog::debug("silhouette refine {}: {} of {} profiles vote, {} of {} vertices", round, accepted, profiles, voting,
                  n);
  }
  const render::TriangleMesh refined = weld.Unweld(mesh, &report->mean_move_m, &report->max_move_m);
  report->seconds = SecondsSince(start);
  spdlog::info("silhouette refine: {} rounds over {} frames; {} of {} outline profiles voted at first, for {} of {} "
               "vertices; vertices moved {:.2f} mm on average (max {:.2f} mm)",
               report->rounds, views.size(), report->votes_first, report->profiles_first, report->voting_vertices_first,
               n, 1e3 * report->mean_move_m, 1e3 * report->max_move_m);
  return refined;
}

}  // namespace relit::reconstruct
