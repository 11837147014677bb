#include "reconstruct/proxy_normals.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numeric>

#include <Eigen/Dense>
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "core/median.h"
#include "core/progress.h"
#include "core/render/scene.h"
#include "core/run_record.h"

namespace relit::reconstruct {

namespace fs = std::filesystem;

RELIT_OPTION_FIELDS(NormalMapOptions,
    .Add("enabled", &S::enabled, "estimate the normal map (needs the flash positions, W/calib/lights.json)")
    .Add("resolution_px", &S::resolution_px, 16, 4096, "normal map texels per side")
    .Add("min_observations", &S::min_observations, 4, 100000,
         "lit observations a texel needs; fewer: the proxy's normal stays")
    .Add("prior_weight", &S::prior_weight, 0.0, 1000.0,
         "pull towards the proxy's normal, in units of the texel's own data weight")
    .Add("max_angle_deg", &S::max_angle_deg, 0.0, 90.0, "largest turn away from the proxy's normal")
    .Add("min_light_cosine", &S::min_light_cosine, 0.0, 1.0,
         "observations lit more grazingly on the proxy are dropped")
    .Add("saturation_level", &S::saturation_level, 0.0, 1e6, "linear level at which a pixel counts as clipped")
    .Add("robust_rounds", &S::robust_rounds, 0, 20, "Huber re-weighting rounds")
    .Add("min_explained_variance", &S::min_explained_variance, 0.0, 1.0,
         "share of a texel's variance the Lambert fit must explain, else the proxy's normal stays (glossy "
         "surfaces); 0 = off")
    .Add("max_residual_ratio", &S::max_residual_ratio, 0.0, 1.0,
         "the estimated normal must cut the Lambert fit's residual with the proxy's normal to this share, else "
         "the proxy's normal stays (a turn that fits only noise); 1 = off"))

nlohmann::json NormalMapStats::ToJson() const {
  return {{"frames", frames},
          {"observations", observations},
          {"texels_seen", texels_seen},
          {"texels_estimated", texels_estimated},
          {"texels_not_lambert", texels_not_lambert},
          {"median_change_deg", median_change_deg},
          {"p90_change_deg", p90_change_deg},
          {"seconds", seconds}};
}

namespace {

// One lit pixel: its texel, the flash's direction / distance^2 at the proxy
// point, and the pixel's linear intensity (mean of R, G, B).
struct Observation {
  int texel;
  Eigen::Vector3f irradiance_direction;  // l / r^2
  float intensity;
};

int TexelOf(const render::Vec2f& uv, int resolution) {
  // As render::Texture reads: texel centres at (i + 0.5) / n, v runs up.
  const int x = std::clamp(static_cast<int>(std::floor(uv.x() * resolution)), 0, resolution - 1);
  const int y = std::clamp(static_cast<int>(std::floor((1.0f - uv.y()) * resolution)), 0, resolution - 1);
  return y * resolution + x;
}

// The observations of one frame. Silhouette pixels (a 4-neighbour misses the
// proxy) are skipped: they mix object and background.
std::vector<Observation> ObserveFrame(const std::string& workspace, const Camera& camera,
                                      const CalibratedFrame& frame, const Eigen::Vector3f& light_m,
                                      const render::Scene& scene, const NormalMapOptions& options,
                                      std::vector<std::pair<int, Eigen::Vector3f>>* proxy_normals) {
  const Image image = ReadImage((fs::path(workspace) / frame.image_linear).string());
  const int width = camera.intrinsics().width, height = camera.intrinsics().height;
  RELIT_REQUIRE(image.width() == width && image.height() == height && image.channels() >= 3, "reconstruct: ",
                frame.image_linear, " is ", image.width(), "x", image.height(), "x", image.channels(),
                ", the undistorted camera is ", width, "x", height, "x3");
  const Eigen::Vector3f origin = camera.Center().cast<float>();
  std::vector<render::Hit> hits(static_cast<size_t>(width) * height);
  std::vector<char> found(hits.size(), 0);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3f direction = camera.PixelToWorldRay({x, y}).cast<float>();
      const size_t i = static_cast<size_t>(y) * width + x;
      found[i] = scene.Intersect(origin, direction, 0.0f, std::numeric_limits<float>::infinity(), &hits[i]);
    }
  }
  const int resolution = options.resolution_px;
  std::vector<Observation> observations;
  for (int y = 1; y + 1 < height; ++y) {
    for (int x = 1; x + 1 < width; ++x) {
      const size_t i = static_cast<size_t>(y) * width + x;
      if (!found[i] || !found[i - 1] || !found[i + 1] || !found[i - width] || !found[i + width]) continue;
      const render::Hit& hit = hits[i];
      const Eigen::Vector3f to_camera = (origin - hit.position).normalized();
      Eigen::Vector3f ng = hit.geometric_normal, ns = hit.shading_normal;
      if (ng.dot(to_camera) < 0) ng = -ng;
      if (ns.dot(ng) < 0) ns = -ns;
      const int texel = TexelOf(hit.uv, resolution);
      proxy_normals->push_back({texel, ns});
      const Eigen::Vector3f to_light = light_m - hit.position;
      const float distance = to_light.norm();
      const Eigen::Vector3f l = to_light / distance;
      if (ns.dot(l) < options.min_light_cosine || ng.dot(l) <= 0) continue;
      const Eigen::Vector3f start = hit.position + 1e-4f * ng;
      if (scene.Occluded(start, l, 0.0f, distance - 2e-4f)) continue;
      const float r = image.at(x, y, 0), g = image.at(x, y, 1), b = image.at(x, y, 2);
      if (std::max({r, g, b}) >= options.saturation_level) continue;
      observations.push_back({texel, l / (distance * distance), (r + g + b) / 3});
    }
  }
  return observations;
}

// The weighted least-squares Lambert fit with a fixed normal n: I = rho l.n + c.
// Returns (rho, c); `residual` (optional) gets the weighted squared residual.
Eigen::Vector2d FitAlongNormal(const Observation* begin, const Observation* end, const std::vector<double>& weights,
                               const Eigen::Vector3f& n, double* residual = nullptr) {
  Eigen::Matrix2d a = Eigen::Matrix2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  for (const Observation* o = begin; o != end; ++o) {
    const Eigen::Vector2d row(o->irradiance_direction.dot(n), 1.0);
    a += weights[o - begin] * row * row.transpose();
    b += weights[o - begin] * row * o->intensity;
  }
  a.diagonal() += Eigen::Vector2d::Constant(1e-12 * (a.trace() + 1));
  const Eigen::Vector2d x = a.ldlt().solve(b);
  if (residual != nullptr) {
    *residual = 0;
    for (const Observation* o = begin; o != end; ++o) {
      const double r = o->intensity - x[0] * o->irradiance_direction.dot(n) - x[1];
      *residual += weights[o - begin] * r * r;
    }
  }
  return x;
}

// Robust fit of (b, c) for one texel's observations; returns the unit normal
// or the proxy's normal when the fit is not trustworthy (`not_lambert` when
// the model explains too little of the texel's variance, or the turned normal
// fits it little better than the proxy's).
Eigen::Vector3f FitTexel(const Observation* begin, const Observation* end, const Eigen::Vector3f& proxy_normal,
                         const NormalMapOptions& options, bool* not_lambert) {
  const int count = static_cast<int>(end - begin);
  std::vector<double> weights(static_cast<size_t>(count), 1.0);
  // The albedo along the proxy normal first (I = rho l.n / r^2 + c), the
  // prior's magnitude.
  const double albedo = std::max(0.0, FitAlongNormal(begin, end, weights, proxy_normal)[0]);
  if (albedo <= 0) return proxy_normal;
  const Eigen::Vector3d prior = albedo * proxy_normal.cast<double>();

  Eigen::Vector4d x = Eigen::Vector4d::Zero();
  for (int round = 0; round <= options.robust_rounds; ++round) {
    Eigen::Matrix4d a = Eigen::Matrix4d::Zero();
    Eigen::Vector4d rhs = Eigen::Vector4d::Zero();
    for (int i = 0; i < count; ++i) {
      const Eigen::Vector4d row(begin[i].irradiance_direction.x(), begin[i].irradiance_direction.y(),
                                begin[i].irradiance_direction.z(), 1.0);
      a += weights[i] * row * row.transpose();
      rhs += weights[i] * row * begin[i].intensity;
    }
    const double scale = options.prior_weight * a.topLeftCorner<3, 3>().trace() / 3 + 1e-12;
    a.topLeftCorner<3, 3>().diagonal().array() += scale;
    rhs.head<3>() += scale * prior;
    x = a.ldlt().solve(rhs);
    std::vector<double> residuals(static_cast<size_t>(count));
    for (int i = 0; i < count; ++i) {
      residuals[i] = std::abs(begin[i].intensity - begin[i].irradiance_direction.cast<double>().dot(x.head<3>()) - x[3]);
    }
    if (round == options.robust_rounds) {
      double weight_sum = 0, mean = 0, total = 0, unexplained = 0;
      for (int i = 0; i < count; ++i) {
        weight_sum += weights[i];
        mean += weights[i] * begin[i].intensity;
      }
      mean /= weight_sum;
      for (int i = 0; i < count; ++i) {
        total += weights[i] * (begin[i].intensity - mean) * (begin[i].intensity - mean);
        unexplained += weights[i] * residuals[i] * residuals[i];
      }
      if (options.min_explained_variance > 0 && !(unexplained <= (1 - options.min_explained_variance) * total)) {
        *not_lambert = true;
        return proxy_normal;
      }
      if (options.max_residual_ratio < 1) {
        double proxy_residual = 0;
        FitAlongNormal(begin, end, weights, proxy_normal, &proxy_residual);
        if (!(unexplained <= options.max_residual_ratio * proxy_residual)) {
          *not_lambert = true;  // the turn fits little more than noise
          return proxy_normal;
        }
      }
      break;
    }
    const double sigma = 1.4826 * Median(residuals) + 1e-9;
    for (int i = 0; i < count; ++i) weights[i] = std::min(1.0, 1.5 * sigma / std::max(residuals[i], 1e-12));
  }
  const Eigen::Vector3d b = x.head<3>();
  if (b.norm() <= 0 || b.dot(proxy_normal.cast<double>()) <= 0) return proxy_normal;
  Eigen::Vector3f n = b.normalized().cast<float>();
  // Clamp to the cone around the proxy normal.
  const float max_angle = static_cast<float>(options.max_angle_deg * M_PI / 180);
  const float angle = std::acos(std::clamp(n.dot(proxy_normal), -1.0f, 1.0f));
  if (angle > max_angle) {
    const Eigen::Vector3f side = (n - n.dot(proxy_normal) * proxy_normal).normalized();
    n = std::cos(max_angle) * proxy_normal + std::sin(max_angle) * side;
  }
  return n;
}

}  // namespace

Image EstimateNormalMap(const std::string& workspace, const CamerasFile& cameras, const LightsFile& lights,
                        const std::vector<const CalibratedFrame*>& frames, const render::TriangleMesh& mesh,
                        const NormalMapOptions& options, NormalMapStats* stats) {
  CheckOptions(options, "normal_map");
  RELIT_REQUIRE(mesh.has_uvs(), "reconstruct: the proxy has no UV atlas; the normal map needs one");
  const auto start = std::chrono::steady_clock::now();
  render::Scene scene;
  scene.AddObject(mesh, render::Material::Lambert(render::Rgb::Constant(0.5f)), 1);
  scene.Commit();

  std::vector<std::pair<const CalibratedFrame*, const FrameLight*>> lit;
  for (const CalibratedFrame* frame : frames) {
    const FrameLight* light = lights.Find(frame->name);
    if (light != nullptr && light->reliable && !frame->image_linear.empty()) lit.push_back({frame, light});
  }
  const int resolution = options.resolution_px;
  const int texels = resolution * resolution;
  std::vector<std::vector<Observation>> per_frame(lit.size());
  std::vector<std::vector<std::pair<int, Eigen::Vector3f>>> normals_per_frame(lit.size());
  {
    Progress progress("normal map: observe", static_cast<int64_t>(lit.size()));
    tbb::parallel_for(size_t(0), lit.size(), [&](size_t i) {
      per_frame[i] = ObserveFrame(workspace, cameras.ViewCamera(*lit[i].first), *lit[i].first,
                                  lit[i].second->position_m.cast<float>(), scene, options, &normals_per_frame[i]);
      progress.Advance();
    });
  }
  // Per texel: the proxy's shading normal summed over every hit (lit or not).
  std::vector<Eigen::Vector3f> proxy_normal_sum(static_cast<size_t>(texels), Eigen::Vector3f::Zero());
  for (const auto& frame_normals : normals_per_frame) {
    for (const auto& [texel, n] : frame_normals) proxy_normal_sum[texel] += n;
  }
  // Group the observations by texel (counting sort).
  std::vector<int> offsets(static_cast<size_t>(texels) + 1, 0);
  for (const auto& obs : per_frame)
    for (const Observation& o : obs) ++offsets[o.texel + 1];
  std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
  std::vector<Observation> sorted(static_cast<size_t>(offsets.back()));
  std::vector<int> fill(offsets.begin(), offsets.end() - 1);
  for (auto& obs : per_frame) {
    for (const Observation& o : obs) sorted[fill[o.texel]++] = o;
    obs = {};
  }

  Image map(resolution, resolution, 3);
  std::vector<double> changes_deg(static_cast<size_t>(texels), -1.0);
  std::vector<char> not_lambert(static_cast<size_t>(texels), 0);
  tbb::parallel_for(0, texels, [&](int t) {
    const Eigen::Vector3f sum = proxy_normal_sum[t];
    if (sum.norm() <= 0) return;  // never seen: zero, the renderer keeps the mesh normal
    const Eigen::Vector3f proxy_normal = sum.normalized();
    Eigen::Vector3f n = proxy_normal;
    const int count = offsets[t + 1] - offsets[t];
    if (count >= options.min_observations) {
      bool rejected = false;
      n = FitTexel(sorted.data() + offsets[t], sorted.data() + offsets[t + 1], proxy_normal, options, &rejected);
      not_lambert[t] = rejected;
      changes_deg[t] = std::acos(std::clamp(n.dot(proxy_normal), -1.0f, 1.0f)) * 180.0 / M_PI;
    }
    for (int c = 0; c < 3; ++c) map.at(t % resolution, t / resolution, c) = n[c];
  });

  NormalMapStats s;
  s.frames = static_cast<int>(lit.size());
  s.observations = static_cast<long long>(sorted.size());
  std::vector<double> changes;
  for (int t = 0; t < texels; ++t) {
    if (proxy_normal_sum[t].norm() > 0) ++s.texels_seen;
    if (changes_deg[t] >= 0) changes.push_back(changes_deg[t]);
    s.texels_not_lambert += not_lambert[t];
  }
  s.texels_estimated = static_cast<int>(changes.size());
  if (!changes.empty()) {
    std::sort(changes.begin(), changes.end());
    s.median_change_deg = changes[changes.size() / 2];
    s.p90_change_deg = changes[changes.size() * 9 / 10];
  }
  s.seconds = SecondsSince(start);
  spdlog::info("normal map: {} frames, {} observations, {} of {} seen texels estimated ({} kept the proxy's "
               "normal: not Lambert), change from the proxy median {:.1f} deg (p90 {:.1f}) in {:.1f} s",
               s.frames, s.observations, s.texels_estimated, s.texels_seen, s.texels_not_lambert, s.median_change_deg,
               s.p90_change_deg, s.seconds);
  if (stats != nullptr) *stats = s;
  return map;
}

}  // namespace relit::reconstruct
