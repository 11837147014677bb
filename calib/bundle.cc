#include "calib/bundle.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include <dlfcn.h>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/progress.h"
#include "core/run_record.h"

namespace relit::calib {

namespace {

// Lens block: fx, fy, cx, cy, k1, k2, p1, p2, k3.
constexpr int kLensSize = 9;

template <typename T>
void Project(const T* q_xyzw, const T* t, const T* lens, const T* point, bool square, T* pixel) {
  const Eigen::Map<const Eigen::Quaternion<T>> q(q_xyzw);
  const Eigen::Matrix<T, 3, 1> p =
      q * Eigen::Map<const Eigen::Matrix<T, 3, 1>>(point) + Eigen::Map<const Eigen::Matrix<T, 3, 1>>(t);
  const T x = p.x() / p.z(), y = p.y() / p.z();
  const T r2 = x * x + y * y;
  const T radial = T(1) + r2 * (lens[4] + r2 * (lens[5] + r2 * lens[8]));
  const T xd = x * radial + T(2) * lens[6] * x * y + lens[7] * (r2 + T(2) * x * x);
  const T yd = y * radial + lens[6] * (r2 + T(2) * y * y) + T(2) * lens[7] * x * y;
  pixel[0] = lens[0] * xd + lens[2];
  pixel[1] = (square ? lens[0] : lens[1]) * yd + lens[3];
}

// The weighted reprojection residual of a world point, shared by the costs.
template <typename T>
void Residual(const T* q, const T* t, const T* lens, const T* point, bool square, const Eigen::Vector2d& observed,
              double weight, T* residual) {
  T pixel[2];
  Project(q, t, lens, point, square, pixel);
  residual[0] = T(weight) * (pixel[0] - T(observed.x()));
  residual[1] = T(weight) * (pixel[1] - T(observed.y()));
}

struct CornerCost {
  Eigen::Vector2d observed;
  Eigen::Vector3d world;
  bool square;
  template <typename T>
  bool operator()(const T* q, const T* t, const T* lens, T* residual) const {
    const T point[3] = {T(world.x()), T(world.y()), T(world.z())};
    Residual(q, t, lens, point, square, observed, 1.0, residual);
    return true;
  }
};

struct PointCost {
  Eigen::Vector2d observed;
  double weight;
  bool square;
  template <typename T>
  bool operator()(const T* q, const T* t, const T* lens, const T* point, T* residual) const {
    Residual(q, t, lens, point, square, observed, weight, residual);
    return true;
  }
};

// A row's motion: its time as a fraction of the readout (ReadoutFraction)
// and the frame's motion.
struct RowMotion {
  double row_fraction;
  Eigen::Vector3d velocity, angular_velocity;
};

struct RollingCornerCost {
  Eigen::Vector2d observed;
  Eigen::Vector3d world;
  bool square;
  RowMotion row;
  template <typename T>
  bool operator()(const T* q, const T* t, const T* lens, const T* readout, T* residual) const {
    const T point[3] = {T(world.x()), T(world.y()), T(world.z())};
    T moved[3];
    MoveForRow(q, t, point, readout[0] * row.row_fraction, row.velocity, row.angular_velocity, moved);
    Residual(q, t, lens, moved, square, observed, 1.0, residual);
    return true;
  }
};

struct RollingPointCost {
  Eigen::Vector2d observed;
  double weight;
  bool square;
  RowMotion row;
  template <typename T>
  bool operator()(const T* q, const T* t, const T* lens, const T* point, const T* readout, T* residual) const {
    T moved[3];
    MoveForRow(q, t, point, readout[0] * row.row_fraction, row.velocity, row.angular_velocity, moved);
    Residual(q, t, lens, moved, square, observed, weight, residual);
    return true;
  }
};

// The rolling-shutter state of the second solve: each frame's motion (held
// fixed) and each video's readout time (refined).
struct RollingShutter {
  std::vector<FrameMotion> motion;
  std::map<std::string, std::array<double, 1>> readout_s;

  // The video's readout block of frame f, null when its motion is unknown.
  double* Readout(const BundleProblem& p, size_t f) {
    if (!motion[f].known) return nullptr;
    auto it = readout_s.find(p.frames[f].video);
    return it == readout_s.end() ? nullptr : it->second.data();
  }
  RowMotion Row(const BundleProblem& p, size_t f, const Eigen::Vector2d& px) const {
    const BundleFrame& frame = p.frames[f];
    const Intrinsics& lens = p.devices.at(frame.device);
    return {ReadoutFraction(px, lens.width, lens.height, frame.rotation_deg), motion[f].centre_velocity_m_s,
            motion[f].angular_velocity_rad_s};
  }
};

RollingShutter MakeRollingShutter(const BundleProblem& p, const BundleOptions& o) {
  std::vector<TimedFrame> timed;
  for (const BundleFrame& f : p.frames) timed.push_back({f.video, f.time_s, f.posed, f.cam_from_world});
  RollingShutter rs;
  rs.motion = EstimateFrameMotion(timed, o.rolling_shutter_max_gap_s);
  for (size_t f = 0; f < p.frames.size(); ++f) {
    if (rs.motion[f].known && p.devices.at(p.frames[f].device).height > 0) rs.readout_s[p.frames[f].video] = {0.0};
  }
  return rs;
}

struct Blocks {
  std::vector<std::array<double, 4>> q;  // x, y, z, w (Eigen order)
  std::vector<std::array<double, 3>> t;
  std::map<std::string, std::array<double, kLensSize>> lens;
};

Blocks ToBlocks(const BundleProblem& p) {
  Blocks b;
  for (const BundleFrame& f : p.frames) {
    const Eigen::Quaterniond& q = f.cam_from_world.rotation;
    b.q.push_back({q.x(), q.y(), q.z(), q.w()});
    const Eigen::Vector3d& t = f.cam_from_world.translation;
    b.t.push_back({t.x(), t.y(), t.z()});
  }
  for (const auto& [name, in] : p.devices) {
    const Distortion& d = in.distortion;
    b.lens[name] = {in.fx, in.fy, in.cx, in.cy, d.k1, d.k2, d.p1, d.p2, d.k3};
  }
  return b;
}

void FromBlocks(const Blocks& b, BundleProblem* p) {
  for (size_t i = 0; i < p->frames.size(); ++i) {
    const Eigen::Quaterniond q(b.q[i][3], b.q[i][0], b.q[i][1], b.q[i][2]);
    p->frames[i].cam_from_world = Rigid3(q, Eigen::Vector3d(b.t[i][0], b.t[i][1], b.t[i][2]));
  }
  for (auto& [name, in] : p->devices) {
    const auto& l = b.lens.at(name);
    in.fx = l[0], in.fy = p->square_pixels ? l[0] : l[1], in.cx = l[2], in.cy = l[3];
    in.distortion = {l[4], l[5], l[6], l[7], l[8]};
  }
}

double Error(const BundleProblem& p, int frame, const Eigen::Vector3d& world, const Eigen::Vector2d& px,
             RollingShutter* rs) {
  const Camera camera(p.devices.at(p.frames[frame].device), p.frames[frame].cam_from_world);
  Eigen::Vector3d seen = world;
  if (const double* readout = rs ? rs->Readout(p, frame) : nullptr) {
    const Rigid3& pose = p.frames[frame].cam_from_world;
    const RowMotion row = rs->Row(p, frame, px);
    MoveForRow(pose.rotation.coeffs().data(), pose.translation.data(), world.data(), readout[0] * row.row_fraction,
               row.velocity, row.angular_velocity, seen.data());
  }
  const Eigen::Vector3d c = camera.cam_from_world() * seen;
  if (!(c.z() > 0)) return std::numeric_limits<double>::infinity();
  return (camera.ProjectCameraPoint(c) - px).norm();
}

// Masks of inlier observations: corners[frame][k], points[point][k].
struct Inliers {
  std::vector<std::vector<bool>> corners, points;
};

Inliers AllInliers(const BundleProblem& p) {
  Inliers in;
  for (const BundleFrame& f : p.frames) in.corners.emplace_back(f.corner_ids.size(), true);
  for (const BundlePoint& pt : p.points) in.points.emplace_back(pt.observations.size(), true);
  return in;
}

// The library of dense Schur's Cholesky factorisation. For n = 6,000 (990
// frames) Ceres' Eigen (Debian's build: SSE2) took 9.7 s, LAPACK from
// OpenBLAS 5.0 s on one busy core, LAPACK from ATLAS (what colmap pulls in)
// 13.6 s; the 990-frame joint refinement 279 s with Eigen, 187 s with
// OpenBLAS. auto: LAPACK when the process's LAPACK is OpenBLAS (Debian's
// libopenblas0-openmp, which tools/install-deps installs), Eigen otherwise.
ceres::DenseLinearAlgebraLibraryType DenseLibrary(const std::string& choice) {
  static const bool openblas = dlsym(RTLD_DEFAULT, "openblas_get_config") != nullptr;
  const bool lapack = ceres::IsDenseLinearAlgebraLibraryTypeAvailable(ceres::LAPACK) &&
                      (choice == "lapack" || (choice == "auto" && openblas));
  RELIT_REQUIRE(lapack || choice != "lapack", "refine.dense_library: lapack, but this Ceres has no LAPACK: use "
                "auto or eigen");
  return lapack ? ceres::LAPACK : ceres::EIGEN;
}

// Solver settings: the Schur complement's size is 6 per frame (pose) plus the
// lenses. Without SfM points (board corners only) it is block diagonal apart
// from the lens rows: sparse Schur (990 frames: 0.6 s against dense 37.6 s).
// With points it is nearly dense (long tracks, cross pairs, the lenses):
// dense Schur up to dense_schur_max_frames, conjugate gradients beyond
// (at 2,990 frames sparse Schur's elimination and CHOLMOD ran 37 minutes
// without finishing; conjugate gradients took 14). iterative_schur serves the joint solve
// only (on corners alone CG took 88 iterations where sparse Schur took 12).
void ConfigureSolver(const BundleOptions& o, int frames, bool has_points, ceres::Solver::Options* options) {
  const std::string& s = o.linear_solver;
  if (s == "dense_schur" || (s == "auto" && has_points && frames <= o.dense_schur_max_frames)) {
    options->linear_solver_type = ceres::DENSE_SCHUR;
  } else if (has_points && (s == "iterative_schur" || s == "auto")) {
    options->linear_solver_type = ceres::ITERATIVE_SCHUR;
    options->preconditioner_type = ceres::SCHUR_JACOBI;
    options->eta = o.iterative_eta;
  } else {
    options->linear_solver_type = ceres::SPARSE_SCHUR;
  }
  options->dense_linear_algebra_library_type = DenseLibrary(o.dense_library);
  options->max_num_iterations = o.max_iterations;
  options->num_threads = o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  options->function_tolerance = o.function_tolerance;
  options->parameter_tolerance = 1e-9;
  options->logging_type = ceres::SILENT;
}

// Per-iteration progress: at trace level always (which iterations buy
// what), at info level once iterations take seconds (a 3,000-frame joint
// solve runs for many minutes), with an upper bound on the time left.
class LogIterations : public ceres::IterationCallback {
 public:
  explicit LogIterations(int max_iterations) : max_iterations_(max_iterations) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    spdlog::trace("bundle: iteration {} cost {:.6e} change {:.3e} step {:.3e} radius {:.2e} linear {} ({:.2f} s)",
                  s.iteration, s.cost, s.cost_change, s.step_norm, s.trust_region_radius,
                  s.linear_solver_iterations, s.iteration_time_in_seconds);
    if (s.iteration > 0 && s.iteration_time_in_seconds >= 2.0) {
      const int left = std::max(0, max_iterations_ - s.iteration);
      const std::string step =
          s.step_is_successful ? fmt::format("cost {:.6e}, {:+.4f} %", s.cost,
                                             -100.0 * s.cost_change / std::max(1e-300, s.cost + s.cost_change))
                               : std::string("step rejected, more damping");
      spdlog::info("bundle: iteration {} of at most {} ({:.1f} s, {}); time left at most {} (the solve usually "
                   "stops far earlier, when the cost stalls)",
                   s.iteration, max_iterations_, s.iteration_time_in_seconds, step,
                   FormatDuration(left * s.iteration_time_in_seconds));
    }
    return ceres::SOLVER_CONTINUE;
  }

 private:
  int max_iterations_;
};

// `rs` (may be null): model the rolling shutter, refining its readout times.
ceres::Solver::Summary Solve(BundleProblem* p, const Inliers& inliers, const BundleOptions& o, RollingShutter* rs) {
  Blocks b = ToBlocks(*p);
  std::vector<std::array<double, 3>> points;
  for (const BundlePoint& pt : p->points) points.push_back({pt.position_m.x(), pt.position_m.y(), pt.position_m.z()});
  ceres::Problem problem;
  std::vector<bool> used_frame(p->frames.size(), false);
  std::map<std::string, bool> used_lens;
  for (size_t f = 0; f < p->frames.size(); ++f) {
    const BundleFrame& frame = p->frames[f];
    if (!frame.posed) continue;
    double* lens = b.lens.at(frame.device).data();
    double* readout = rs ? rs->Readout(*p, f) : nullptr;
    for (size_t k = 0; k < frame.corner_ids.size(); ++k) {
      if (!inliers.corners[f][k]) continue;
      const Eigen::Vector3d& world = p->corners_world.at(frame.corner_ids[k]);
      if (readout) {
        auto* cost = new ceres::AutoDiffCostFunction<RollingCornerCost, 2, 4, 3, kLensSize, 1>(new RollingCornerCost{
            frame.corners_px[k], world, p->square_pixels, rs->Row(*p, f, frame.corners_px[k])});
        problem.AddResidualBlock(cost, new ceres::HuberLoss(o.huber_px), b.q[f].data(), b.t[f].data(), lens,
                                 readout);
      } else {
        auto* cost = new ceres::AutoDiffCostFunction<CornerCost, 2, 4, 3, kLensSize>(
            new CornerCost{frame.corners_px[k], world, p->square_pixels});
        problem.AddResidualBlock(cost, new ceres::HuberLoss(o.huber_px), b.q[f].data(), b.t[f].data(), lens);
      }
      used_frame[f] = true;
      used_lens[frame.device] = true;
    }
  }
  for (size_t i = 0; i < p->points.size(); ++i) {
    // A point needs two inlier observations, else its depth is free.
    int usable = 0;
    for (size_t k = 0; k < p->points[i].observations.size(); ++k) {
      usable += inliers.points[i][k] && p->frames[p->points[i].observations[k].frame].posed;
    }
    if (usable < 2) continue;
    for (size_t k = 0; k < p->points[i].observations.size(); ++k) {
      const PointObservation& obs = p->points[i].observations[k];
      const BundleFrame& frame = p->frames[obs.frame];
      if (!inliers.points[i][k] || !frame.posed || o.point_weight <= 0) continue;
      double* lens = b.lens.at(frame.device).data();
      auto* loss = new ceres::HuberLoss(o.huber_px * o.point_weight);
      if (double* readout = rs ? rs->Readout(*p, obs.frame) : nullptr) {
        auto* cost = new ceres::AutoDiffCostFunction<RollingPointCost, 2, 4, 3, kLensSize, 3, 1>(new RollingPointCost{
            obs.pixel_px, o.point_weight, p->square_pixels, rs->Row(*p, obs.frame, obs.pixel_px)});
        problem.AddResidualBlock(cost, loss, b.q[obs.frame].data(), b.t[obs.frame].data(), lens, points[i].data(),
                                 readout);
      } else {
        auto* cost = new ceres::AutoDiffCostFunction<PointCost, 2, 4, 3, kLensSize, 3>(
            new PointCost{obs.pixel_px, o.point_weight, p->square_pixels});
        problem.AddResidualBlock(cost, loss, b.q[obs.frame].data(), b.t[obs.frame].data(), lens, points[i].data());
      }
      used_frame[obs.frame] = true;
      used_lens[frame.device] = true;
    }
  }
  for (size_t f = 0; f < p->frames.size(); ++f) {
    if (used_frame[f]) problem.SetManifold(b.q[f].data(), new ceres::EigenQuaternionManifold);
  }
  for (auto& [name, lens] : b.lens) {
    if (!used_lens[name]) continue;
    if (p->fixed_lens.count(name) && p->fixed_lens.at(name)) {
      problem.SetParameterBlockConstant(lens.data());
    } else {
      std::vector<int> constant;
      if (p->square_pixels) constant.push_back(1);
      if (!p->refine_tangential) {
        constant.push_back(6);
        constant.push_back(7);
      }
      if (!p->refine_k3) constant.push_back(8);
      if (!constant.empty()) problem.SetManifold(lens.data(), new ceres::SubsetManifold(kLensSize, constant));
    }
  }
  if (rs) {
    for (auto& [video, readout] : rs->readout_s) {
      if (!problem.HasParameterBlock(readout.data())) continue;
      problem.SetParameterLowerBound(readout.data(), 0, 0.0);
      problem.SetParameterUpperBound(readout.data(), 0, o.max_readout_s);
    }
  }
  ceres::Solver::Options options;
  bool has_points = false;
  for (auto& point : points) {
    if (!problem.HasParameterBlock(point.data())) continue;
    if (p->fixed_points) problem.SetParameterBlockConstant(point.data());
    has_points = !p->fixed_points;
  }
  ConfigureSolver(o, static_cast<int>(std::count(used_frame.begin(), used_frame.end(), true)), has_points,
                  &options);
  if (options.linear_solver_type != ceres::DENSE_SCHUR && has_points) {
    // Points first: Schur elimination leaves the reduced camera system, whose
    // sparsity follows the frames that share points.
    auto* ordering = new ceres::ParameterBlockOrdering;
    for (auto& point : points) {
      if (problem.HasParameterBlock(point.data())) ordering->AddElementToGroup(point.data(), 0);
    }
    for (size_t f = 0; f < p->frames.size(); ++f) {
      if (!used_frame[f]) continue;
      ordering->AddElementToGroup(b.q[f].data(), 1);
      ordering->AddElementToGroup(b.t[f].data(), 1);
    }
    for (auto& [name, lens] : b.lens) {
      if (used_lens[name]) ordering->AddElementToGroup(lens.data(), 1);
    }
    if (rs) {
      for (auto& [video, readout] : rs->readout_s) {
        if (problem.HasParameterBlock(readout.data())) ordering->AddElementToGroup(readout.data(), 1);
      }
    }
    if (ordering->NumElements() > 0 && ordering->GroupSize(0) > 0) {
      options.linear_solver_ordering.reset(ordering);
    } else {
      delete ordering;
    }
  }
  LogIterations log_iterations(options.max_num_iterations);
  if (spdlog::should_log(spdlog::level::info)) options.callbacks.push_back(&log_iterations);
  ceres::Solver::Summary summary;
  if (problem.NumResidualBlocks() > 0) ceres::Solve(options, &problem, &summary);
  FromBlocks(b, p);
  for (size_t i = 0; i < p->points.size(); ++i) {
    p->points[i].position_m = Eigen::Vector3d(points[i][0], points[i][1], points[i][2]);
  }
  for (size_t f = 0; f < p->frames.size(); ++f) {
    if (!used_frame[f]) p->frames[f].posed = false;
  }
  return summary;
}

// Reprojection errors of one kind of observation: those within outlier_px
// are summed (squared), the others only counted.
struct ErrorTally {
  explicit ErrorTally(double outlier_px) : outlier_px(outlier_px) {}

  double outlier_px;
  double squared_sum = 0;
  int inliers = 0, outliers = 0;

  // Adds error `e` (pixels); returns whether it is an inlier.
  bool Add(double e) {
    if (!(e <= outlier_px)) {  // NaN too
      ++outliers;
      return false;
    }
    squared_sum += e * e;
    ++inliers;
    return true;
  }
  double Rms() const { return inliers > 0 ? std::sqrt(squared_sum / inliers) : 0.0; }
};

BundleStats Evaluate(const BundleProblem& p, double outlier_px, Inliers* inliers, RollingShutter* rs) {
  BundleStats s;
  std::map<std::string, std::pair<double, int>> by_device;
  ErrorTally corners(outlier_px), points(outlier_px);
  s.frame_corner_rms_px.assign(p.frames.size(), 0.0);
  for (size_t f = 0; f < p.frames.size(); ++f) {
    const BundleFrame& frame = p.frames[f];
    if (!frame.posed) continue;
    double frame_sum = 0;
    int frame_count = 0;
    for (size_t k = 0; k < frame.corner_ids.size(); ++k) {
      const double e = Error(p, static_cast<int>(f), p.corners_world.at(frame.corner_ids[k]), frame.corners_px[k], rs);
      const bool inlier = corners.Add(e);
      if (inliers) inliers->corners[f][k] = inlier;
      if (!inlier) continue;
      frame_sum += e * e;
      ++frame_count;
      by_device[frame.device].first += e * e;
      by_device[frame.device].second += 1;
    }
    if (frame_count > 0) s.frame_corner_rms_px[f] = std::sqrt(frame_sum / frame_count);
  }
  for (size_t i = 0; i < p.points.size(); ++i) {
    for (size_t k = 0; k < p.points[i].observations.size(); ++k) {
      const PointObservation& obs = p.points[i].observations[k];
      if (!p.frames[obs.frame].posed) continue;
      const double e = Error(p, obs.frame, p.points[i].position_m, obs.pixel_px, rs);
      const bool inlier = points.Add(e);
      if (inliers) inliers->points[i][k] = inlier;
    }
  }
  s.corner_observations = corners.inliers;
  s.corner_outliers = corners.outliers;
  s.corner_rms_px = corners.Rms();
  s.point_observations = points.inliers;
  s.point_outliers = points.outliers;
  s.point_rms_px = points.Rms();
  for (const auto& [device, sum] : by_device) s.corner_rms_px_by_device[device] = std::sqrt(sum.first / sum.second);
  return s;
}

}  // namespace

std::vector<BundlePoint> KeepLongestTracks(std::vector<BundlePoint> points, size_t frames, int per_frame,
                                           std::vector<BundlePoint>* dropped) {
  if (per_frame <= 0) return points;
  std::stable_sort(points.begin(), points.end(), [](const BundlePoint& a, const BundlePoint& b) {
    return a.observations.size() > b.observations.size();
  });
  std::vector<int> observations(frames, 0);
  std::vector<BundlePoint> kept;
  for (BundlePoint& point : points) {
    bool needed = false;
    for (const PointObservation& obs : point.observations) needed = needed || observations[obs.frame] < per_frame;
    if (!needed) {
      if (dropped) dropped->push_back(std::move(point));
      continue;
    }
    for (const PointObservation& obs : point.observations) ++observations[obs.frame];
    kept.push_back(std::move(point));
  }
  return kept;
}

BundleStats RefineBundle(BundleProblem* problem, const BundleOptions& options) {
  RELIT_CHECK(problem->corners_world.size() > 0);
  const auto start = std::chrono::steady_clock::now();
  Inliers inliers = AllInliers(*problem);
  BundleOptions first_options = options;
  if (options.first_function_tolerance > 0) first_options.function_tolerance = options.first_function_tolerance;
  if (options.first_max_iterations > 0) first_options.max_iterations = options.first_max_iterations;
  ceres::Solver::Summary first = Solve(problem, inliers, first_options, nullptr);
  Evaluate(*problem, options.outlier_px, &inliers, nullptr);
  BundleOptions final_options = options;
  if (options.final_huber_px > 0) final_options.huber_px = options.final_huber_px;
  // The motion needs poses: those of the first solve are good to ~1 mm,
  // which over a readout of milliseconds is far below a pixel.
  RollingShutter rs;
  if (options.rolling_shutter) rs = MakeRollingShutter(*problem, options);
  RollingShutter* rs_used = rs.readout_s.empty() ? nullptr : &rs;
  ceres::Solver::Summary second = Solve(problem, inliers, final_options, rs_used);
  BundleStats stats = Evaluate(*problem, options.outlier_px, nullptr, rs_used);
  for (const auto& [video, readout] : rs.readout_s) stats.readout_s[video] = readout[0];
  for (size_t f = 0; f < problem->frames.size(); ++f) {
    if (rs_used && rs.motion[f].known) stats.moving_frames[problem->frames[f].video]++;
  }
  stats.iterations = static_cast<int>(first.iterations.size() + second.iterations.size());
  stats.final_iterations = static_cast<int>(second.iterations.size());
  stats.initial_cost = first.initial_cost;
  stats.final_cost = second.final_cost;
  stats.linear_solver = ceres::LinearSolverTypeToString(second.linear_solver_type_used);
  stats.dense_library = second.linear_solver_type_used == ceres::DENSE_SCHUR
                            ? ceres::DenseLinearAlgebraLibraryTypeToString(second.dense_linear_algebra_library_type)
                            : "";
  stats.solve_s = SecondsSince(start);
  spdlog::info("bundle: {} frames, {} points, {}{} ({} + {} iterations, {:.1f} s)", problem->frames.size(),
               problem->points.size(), stats.linear_solver, stats.dense_library.empty() ? "" : " " + stats.dense_library,
               first.iterations.size(), second.iterations.size(), stats.solve_s);
  for (const auto& [video, readout] : stats.readout_s) {
    spdlog::info("bundle: {} rolling shutter: readout {:.2f} ms ({} frames with motion)", video, readout * 1e3,
                 stats.moving_frames[video]);
  }
  // Where the time goes (residual/Jacobian evaluation vs linear solver) and why Ceres stopped.
  spdlog::debug("bundle: first solve: {}", first.FullReport());
  spdlog::debug("bundle: second solve: {}", second.FullReport());
  return stats;
}

BundleStats EvaluateBundle(const BundleProblem& problem, double outlier_px) {
  return Evaluate(problem, outlier_px, nullptr, nullptr);
}

}  // namespace relit::calib
