// Preview texture bake: the trained model rendered under uniform white light
// from views around the object, unwrapped into the proxy's UV atlas
// (interop.h).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>

#include <spdlog/spdlog.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/color.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "relight/cue_frames.h"
#include "relight/interop.h"
#include "relight/render_stage.h"

namespace relit::relight {

namespace {

constexpr float kMinCoverage = 0.9f;

// A texel whose centre lies on the surface.
struct TexelSample {
  int texel = 0;                   // y * R + x
  Eigen::Vector3f position;        // world
  Eigen::Vector3f normal;          // interpolated shading normal, unit
  Eigen::Vector3f face_normal;     // geometric, on the shading normal's side
};

// Rasterises every triangle in UV space: texel (x, y) has its centre at
// u = (x + 0.5) / R, v = 1 - (y + 0.5) / R (row 0 at v = 1).
std::vector<TexelSample> RasteriseAtlas(const render::TriangleMesh& mesh, int resolution, Image* inside) {
  std::vector<int> owner(static_cast<size_t>(resolution) * resolution, -1);
  std::vector<TexelSample> samples;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    Eigen::Vector2d p[3];
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2f& uv = mesh.uvs[t[k]];
      p[k] = Eigen::Vector2d(uv.x() * resolution - 0.5, (1.0 - uv.y()) * resolution - 0.5);
    }
    const double area = (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[1] - p[0]).y() * (p[2] - p[0]).x();
    if (std::abs(area) < 1e-12) continue;
    const int x0 = std::max(0, static_cast<int>(std::ceil(std::min({p[0].x(), p[1].x(), p[2].x()}))));
    const int x1 = std::min(resolution - 1, static_cast<int>(std::floor(std::max({p[0].x(), p[1].x(), p[2].x()}))));
    const int y0 = std::max(0, static_cast<int>(std::ceil(std::min({p[0].y(), p[1].y(), p[2].y()}))));
    const int y1 = std::min(resolution - 1, static_cast<int>(std::floor(std::max({p[0].y(), p[1].y(), p[2].y()}))));
    const Eigen::Vector3f& a = mesh.positions[t[0]];
    const Eigen::Vector3f& b = mesh.positions[t[1]];
    const Eigen::Vector3f& c = mesh.positions[t[2]];
    const Eigen::Vector3f face = (b - a).cross(c - a).normalized();
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const Eigen::Vector2d q(x, y);
        auto edge = [&](const Eigen::Vector2d& e0, const Eigen::Vector2d& e1) {
          return ((e1 - e0).x() * (q - e0).y() - (e1 - e0).y() * (q - e0).x()) / area;
        };
        const double w0 = edge(p[1], p[2]), w1 = edge(p[2], p[0]), w2 = edge(p[0], p[1]);
        const double tolerance = -1e-9;
        if (w0 < tolerance || w1 < tolerance || w2 < tolerance) continue;
        const int texel = y * resolution + x;
        if (owner[texel] >= 0) continue;  // shared edge: the first triangle keeps it
        owner[texel] = static_cast<int>(samples.size());
        TexelSample s;
        s.texel = texel;
        s.position = static_cast<float>(w0) * a + static_cast<float>(w1) * b + static_cast<float>(w2) * c;
        Eigen::Vector3f n = static_cast<float>(w0) * mesh.normals[t[0]] + static_cast<float>(w1) * mesh.normals[t[1]] +
                            static_cast<float>(w2) * mesh.normals[t[2]];
        s.normal = n.norm() > 1e-12f ? n.normalized() : face;
        s.face_normal = face.dot(s.normal) >= 0 ? face : -face;
        samples.push_back(s);
        inside->at(x, y, 0) = 1;
      }
    }
  }
  return samples;
}

// Bilinear lookup of a premultiplied RGBA render at a pixel position
// (OpenCV convention). False outside the image.
bool SampleRgba(const Image& image, const Eigen::Vector2d& pixel, Eigen::Vector4f* rgba) {
  if (!(pixel.x() >= 0 && pixel.y() >= 0 && pixel.x() <= image.width() - 1 && pixel.y() <= image.height() - 1)) {
    return false;
  }
  const int x0 = std::max(0, std::min(static_cast<int>(pixel.x()), image.width() - 2));
  const int y0 = std::max(0, std::min(static_cast<int>(pixel.y()), image.height() - 2));
  const int x1 = std::min(x0 + 1, image.width() - 1), y1 = std::min(y0 + 1, image.height() - 1);
  const float fx = static_cast<float>(pixel.x() - x0), fy = static_cast<float>(pixel.y() - y0);
  rgba->setZero();
  const std::pair<int, int> corners[4] = {{x0, y0}, {x1, y0}, {x0, y1}, {x1, y1}};
  const float weights[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  for (int k = 0; k < 4; ++k) {
    const float* p = image.pixel(corners[k].first, corners[k].second);
    for (int c = 0; c < 4; ++c) (*rgba)[c] += weights[k] * p[c];
  }
  return true;
}

// Fills texels with zero weight from coarser levels of a weighted pyramid
// (push-pull, Gortler et al. 1996): pull averages valid texels 2x2 level by
// level, push fills each empty texel from the coarser level, bilinearly.
void PushPullFill(Image* colour, const std::vector<float>& valid_in) {
  struct Level {
    int n = 0;
    std::vector<Eigen::Vector3f> c;
    std::vector<float> w;
  };
  std::vector<Level> levels(1);
  levels[0].n = colour->width();
  levels[0].c.resize(valid_in.size());
  levels[0].w = valid_in;
  for (size_t i = 0; i < valid_in.size(); ++i) {
    const float* p = &colour->data()[i * 3];
    levels[0].c[i] = Eigen::Vector3f(p[0], p[1], p[2]);
  }
  while (levels.back().n > 1) {
    const Level& fine = levels.back();  // valid until the push_back below
    Level coarse;
    coarse.n = fine.n / 2;
    coarse.c.assign(static_cast<size_t>(coarse.n) * coarse.n, Eigen::Vector3f::Zero());
    coarse.w.assign(coarse.c.size(), 0.f);
    for (int y = 0; y < coarse.n; ++y) {
      for (int x = 0; x < coarse.n; ++x) {
        Eigen::Vector3f sum = Eigen::Vector3f::Zero();
        float weight = 0;
        for (int dy = 0; dy < 2; ++dy) {
          for (int dx = 0; dx < 2; ++dx) {
            const size_t i = static_cast<size_t>(2 * y + dy) * fine.n + 2 * x + dx;
            sum += fine.w[i] * fine.c[i];
            weight += fine.w[i];
          }
        }
        const size_t o = static_cast<size_t>(y) * coarse.n + x;
        if (weight > 0) coarse.c[o] = sum / weight;
        coarse.w[o] = std::min(1.f, weight);
      }
    }
    levels.push_back(std::move(coarse));
  }
  for (int l = static_cast<int>(levels.size()) - 2; l >= 0; --l) {
    Level& fine = levels[l];
    const Level& coarse = levels[l + 1];
    for (int y = 0; y < fine.n; ++y) {
      for (int x = 0; x < fine.n; ++x) {
        const size_t i = static_cast<size_t>(y) * fine.n + x;
        if (fine.w[i] >= 1) continue;
        // Bilinear in the (already complete) coarser level: no blocks.
        const float cx = std::clamp((x + 0.5f) / 2 - 0.5f, 0.f, coarse.n - 1.f);
        const float cy = std::clamp((y + 0.5f) / 2 - 0.5f, 0.f, coarse.n - 1.f);
        const int x0 = static_cast<int>(cx), y0 = static_cast<int>(cy);
        const int x1 = std::min(x0 + 1, coarse.n - 1), y1 = std::min(y0 + 1, coarse.n - 1);
        const float fx = cx - x0, fy = cy - y0;
        auto at = [&](int u, int v) { return coarse.c[static_cast<size_t>(v) * coarse.n + u]; };
        const Eigen::Vector3f parent = (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x1, y0)) +
                                       fy * ((1 - fx) * at(x0, y1) + fx * at(x1, y1));
        fine.c[i] = fine.w[i] * fine.c[i] + (1 - fine.w[i]) * parent;
      }
    }
  }
  for (size_t i = 0; i < levels[0].c.size(); ++i) {
    for (int k = 0; k < 3; ++k) colour->data()[i * 3 + k] = levels[0].c[i][k];
  }
}

}  // namespace

CueLight UniformWhiteLight(const AssetDescription& asset, const InteropOptions& options) {
  CueLight light;
  light.kind = CueLight::Kind::kEnvironment;
  const Image white(8, 4, 3, 1.0f);
  light.environment =
      render::EnvironmentLight(white, static_cast<float>(options.bake_environment_radiance * asset.flash_intensity));
  return light;
}

std::vector<Camera> BakeViews(const Intrinsics& intrinsics, const Eigen::Vector3d& centre, double distance_m,
                              int count) {
  // Equal-area spiral: sin(elevation) uniform between 5 and 80 degrees,
  // azimuths advancing by the golden angle.
  const double z0 = std::sin(5 * M_PI / 180), z1 = std::sin(80 * M_PI / 180);
  const double golden = M_PI * (3 - std::sqrt(5.0));
  std::vector<Camera> views;
  for (int i = 0; i < count; ++i) {
    const double z = z0 + (z1 - z0) * (i + 0.5) / count;
    const double r = std::sqrt(1 - z * z), azimuth = golden * i;
    const Eigen::Vector3d direction(r * std::cos(azimuth), r * std::sin(azimuth), z);
    views.emplace_back(intrinsics, LookAt(centre + distance_m * direction, centre, Eigen::Vector3d::UnitZ()));
  }
  return views;
}

Eigen::Vector3f SampleTexture(const Image& texture, const Eigen::Vector2f& uv) {
  const int n = texture.width(), m = texture.height();
  const float x = std::clamp(uv.x() * n - 0.5f, 0.f, static_cast<float>(n - 1));
  const float y = std::clamp((1 - uv.y()) * m - 0.5f, 0.f, static_cast<float>(m - 1));
  const int x0 = std::min(static_cast<int>(x), n - 1), y0 = std::min(static_cast<int>(y), m - 1);
  const int x1 = std::min(x0 + 1, n - 1), y1 = std::min(y0 + 1, m - 1);
  const float fx = x - x0, fy = y - y0;
  Eigen::Vector3f result = Eigen::Vector3f::Zero();
  for (int k = 0; k < 3; ++k) {
    result[k] = (1 - fx) * (1 - fy) * texture.at(x0, y0, k) + fx * (1 - fy) * texture.at(x1, y0, k) +
                (1 - fx) * fy * texture.at(x0, y1, k) + fx * fy * texture.at(x1, y1, k);
  }
  return result;
}

Image TonemapToSrgb(const BakedTexture& bake, double exposure) {
  Image srgb(bake.resolution_px, bake.resolution_px, {"R", "G", "B", "A"});
  for (int y = 0; y < bake.resolution_px; ++y) {
    for (int x = 0; x < bake.resolution_px; ++x) {
      for (int c = 0; c < 3; ++c) {
        srgb.at(x, y, c) = LinearToSrgb(std::clamp(static_cast<float>(exposure) * bake.linear.at(x, y, c), 0.f, 1.f));
      }
      srgb.at(x, y, 3) = 1;
    }
  }
  return srgb;
}

BakedTexture UnwrapViews(const render::TriangleMesh& mesh_in, int resolution, const std::vector<Camera>& views,
                         const std::function<Image(size_t view)>& render_view) {
  render::TriangleMesh mesh = mesh_in;
  RELIT_REQUIRE(mesh.has_uvs(), "bake: the mesh has no UVs");
  RELIT_REQUIRE(resolution >= 1 && (resolution & (resolution - 1)) == 0, "bake: the texture size ", resolution,
                " is not a power of two");
  if (!mesh.has_normals()) mesh.ComputeVertexNormals();
  BakedTexture bake;
  bake.resolution_px = resolution;
  bake.views = views;
  bake.inside = Image(resolution, resolution, 1, 0.f);
  const std::vector<TexelSample> samples = RasteriseAtlas(mesh, resolution, &bake.inside);
  RELIT_REQUIRE(!samples.empty(), "bake: no texel centre of the ", resolution, "² atlas falls on a triangle");
  // Visibility rays against the same mesh (the geometry the renders show).
  render::Scene scene;
  scene.AddObject(mesh, render::Material::Lambert(render::Rgb::Constant(0.5f)), 1);
  scene.Commit();
  const Eigen::AlignedBox3f bounds = mesh.Bounds();
  const float epsilon = std::max(1e-6f, 1e-4f * bounds.diagonal().norm());

  std::vector<Eigen::Vector3f> sum_rgb(samples.size(), Eigen::Vector3f::Zero());
  std::vector<float> sum_alpha(samples.size(), 0.f);
  Progress progress("bake preview texture", static_cast<int64_t>(views.size()));
  for (size_t v = 0; v < views.size(); ++v) {
    const Camera& camera = views[v];
    auto render_start = std::chrono::steady_clock::now();
    const Image rgba = render_view(v);
    RELIT_CHECK(rgba.width() == camera.intrinsics().width && rgba.height() == camera.intrinsics().height &&
                rgba.channels() == 4);
    bake.render_seconds += SecondsSince(render_start);
    auto accumulate_start = std::chrono::steady_clock::now();
    const Eigen::Vector3f centre = camera.Center().cast<float>();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, samples.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i != r.end(); ++i) {
        const TexelSample& s = samples[i];
        const Eigen::Vector3f to_camera = centre - s.position;
        const float distance_to_camera = to_camera.norm();
        const Eigen::Vector3f direction = to_camera / distance_to_camera;
        const float cosine = s.normal.dot(direction);
        // Grazing views smear the texture; back faces are not seen.
        if (cosine < 0.05f || s.face_normal.dot(direction) <= 0) continue;
        Eigen::Vector2d pixel;
        if (!camera.Project(s.position.cast<double>(), &pixel)) continue;
        Eigen::Vector4f value;
        // Only where the object covers the pixel: the networks' colour at the
        // silhouette is unreliable (measured: 2-3 % darker on the test scene).
        if (!SampleRgba(rgba, pixel, &value) || value[3] < kMinCoverage) continue;
        const Eigen::Vector3f origin = s.position + epsilon * s.face_normal;
        if (scene.Occluded(origin, direction, epsilon, distance_to_camera - 2 * epsilon)) continue;
        // Premultiplied colour and coverage, both weighted by the cosine:
        // the ratio is the coverage- and cosine-weighted straight colour.
        sum_rgb[i] += cosine * value.head<3>();
        sum_alpha[i] += cosine * value[3];
      }
    });
    bake.accumulate_seconds += SecondsSince(accumulate_start);
    progress.Advance();
  }
  progress.Finish();

  bake.linear = Image(resolution, resolution, {"R", "G", "B"});
  bake.weight = Image(resolution, resolution, 1, 0.f);
  std::vector<float> valid(static_cast<size_t>(resolution) * resolution, 0.f);
  size_t seen = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const int texel = samples[i].texel;
    bake.weight.data()[texel] = sum_alpha[i];
    if (sum_alpha[i] < kSeenWeight) continue;  // no view saw it (well enough)
    const Eigen::Vector3f colour = sum_rgb[i] / sum_alpha[i];
    for (int k = 0; k < 3; ++k) bake.linear.data()[static_cast<size_t>(texel) * 3 + k] = colour[k];
    valid[texel] = 1;
    ++seen;
  }
  PushPullFill(&bake.linear, valid);
  spdlog::info("bake: {} of {} surface texels seen by {} views (render {:.1f} s, unwrap {:.1f} s)", seen,
               samples.size(), views.size(), bake.render_seconds, bake.accumulate_seconds);
  return bake;
}

BakedTexture BakePreviewTexture(RelitRenderer& renderer, const render::TriangleMesh& mesh,
                                const InteropOptions& options, int cue_samples_per_pixel) {
  CheckOptions(options, "export");
  const AssetDescription& asset = renderer.asset();
  Intrinsics intrinsics = asset.camera;
  if (options.bake_width_px > 0) {
    const int height = std::max(4, static_cast<int>(std::lround(
                                       options.bake_width_px * double(intrinsics.height) / intrinsics.width / 4)) * 4);
    intrinsics = intrinsics.Scaled(options.bake_width_px, height);
  }
  const double distance = asset.capture_distance_m > 0 ? asset.capture_distance_m : 3 * asset.object_radius_m;
  const std::vector<Camera> views = BakeViews(intrinsics, asset.object_centre_m, distance, options.bake_views);
  const CueLight light = UniformWhiteLight(asset, options);
  CueRenderSettings settings;
  settings.samples_per_pixel =
      options.bake_samples_per_pixel > 0 ? options.bake_samples_per_pixel : std::max(1, cue_samples_per_pixel);
  return UnwrapViews(mesh, options.bake_texture_px, views, [&](size_t v) {
    settings.seed = 9100 + v;
    return renderer.Render(views[v], light, settings);
  });
}

}  // namespace relit::relight
