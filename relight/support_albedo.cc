#include "relight/support_albedo.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "core/median.h"

namespace relit::relight {

namespace {

using render::Vec3f;

enum class PlanePart { kNone, kPaper, kBoard, kTable };

bool OnPlane(const render::Hit& hit) {
  return hit.object_id == kSupportBoardObjectId || hit.object_id == kSupportTableObjectId;
}

// What the ray through pixel (x, y) of `camera` sees first: white paper
// (all four neighbouring rays too, so no pixel straddles the print), other
// parts of the board (the print's ink, or paper next to it), the table, or
// something else (the object, nothing). Board and table pixels need their
// four neighbours on the plane too: a pixel at the proxy's silhouette may
// see the object in the photo.
PlanePart SeenPart(const render::Scene& scene, const SupportPlane& plane, const Camera& camera, double x, double y,
                   render::Hit* hit) {
  const Vec3f origin = camera.Center().cast<float>();
  auto trace = [&](double px, double py, render::Hit* h) {
    const Vec3f direction = camera.PixelToWorldRay({px, py}).cast<float>();
    return scene.Intersect(origin, direction, 1e-4f, 1e4f, h);
  };
  if (!trace(x, y, hit) || !OnPlane(*hit)) return PlanePart::kNone;
  const float paper_threshold = static_cast<float>(0.5 * (plane.paper_albedo + plane.ink_albedo));
  auto is_paper = [&](const render::Hit& h) {
    return h.object_id == kSupportBoardObjectId &&
           scene.material(h.material).At(h.uv).diffuse.x() > paper_threshold;
  };
  bool all_paper = is_paper(*hit);
  for (const auto& [dx, dy] : std::array<std::pair<double, double>, 4>{{{-1, 0}, {1, 0}, {0, -1}, {0, 1}}}) {
    render::Hit neighbour;
    if (!trace(x + dx, y + dy, &neighbour) || !OnPlane(neighbour)) return PlanePart::kNone;
    all_paper = all_paper && is_paper(neighbour);
  }
  if (hit->object_id == kSupportTableObjectId) return PlanePart::kTable;
  return all_paper ? PlanePart::kPaper : PlanePart::kBoard;
}

struct BoardSample {
  int texel;
  float value[3];
};

struct FrameSamples {
  std::vector<double> paper[3], table[3];  // radiance / (cos / (pi r^2)) per channel
  std::vector<BoardSample> board;          // the same, per texel of the board's map (paper included)
};

FrameSamples MeasureFrame(const render::Scene& scene, const SupportPlane& plane, const SupportAlbedoFrame& frame,
                          const SupportAlbedoOptions& options, int map_width, int map_height) {
  FrameSamples samples;
  const Image image = ReadImage(frame.image_path);
  const Vec3f light = frame.light_position_m.cast<float>();
  const Vec3f eye = frame.camera.Center().cast<float>();
  for (int y = 0; y < image.height(); y += options.pixel_stride) {
    for (int x = 0; x < image.width(); x += options.pixel_stride) {
      render::Hit hit;
      const PlanePart part = SeenPart(scene, plane, frame.camera, x + 0.5, y + 0.5, &hit);
      if (part == PlanePart::kNone) continue;
      const float* radiance = image.pixel(x, y);
      if (std::max({radiance[0], radiance[1], radiance[2]}) >= options.saturation_level) continue;
      const Vec3f to_light = light - hit.position;
      const float distance = to_light.norm();
      const float cos_light = to_light.z() / distance;  // the plane's normal is +Z
      const float cos_eye = (eye - hit.position).normalized().z();
      if (cos_light < options.min_cosine || cos_eye < options.min_cosine) continue;
      const Vec3f start = hit.position + 1e-4f * Vec3f::UnitZ();
      if (scene.Occluded(start, to_light / distance, 0.0f, distance - 1e-3f)) continue;  // in the object's shadow
      const double irradiance = cos_light / (M_PI * distance * distance);
      if (part == PlanePart::kTable) {
        for (int c = 0; c < 3; ++c) samples.table[c].push_back(radiance[c] / irradiance);
        continue;
      }
      if (part == PlanePart::kPaper) {
        for (int c = 0; c < 3; ++c) samples.paper[c].push_back(radiance[c] / irradiance);
      }
      if (map_width > 0) {
        // Texel rows run from the print's top (v = 1), as render::Texture reads them.
        const int tx = std::clamp(static_cast<int>(hit.uv.x() * map_width), 0, map_width - 1);
        const int ty = std::clamp(static_cast<int>((1.0f - hit.uv.y()) * map_height), 0, map_height - 1);
        BoardSample s{ty * map_width + tx, {}};
        for (int c = 0; c < 3; ++c) s.value[c] = static_cast<float>(radiance[c] / irradiance);
        samples.board.push_back(s);
      }
    }
  }
  return samples;
}

// The board's map: the median of each texel's samples where it has enough,
// the print (area-averaged to the map's texels) elsewhere.
Image BoardAlbedoMap(const Image& print_albedo, int width, int height,
                     std::vector<std::vector<BoardSample>> per_texel, const SupportAlbedoOptions& options,
                     double* measured_fraction) {
  cv::Mat print_small;
  cv::resize(print_albedo.ToMat(), print_small, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  Image map = Image::FromMat(print_small);
  int64_t measured = 0;
  for (int t = 0; t < width * height; ++t) {
    std::vector<BoardSample>& s = per_texel[t];
    if (static_cast<int>(s.size()) < options.min_texel_samples) continue;
    ++measured;
    for (int c = 0; c < 3; ++c) {
      std::vector<double> values(s.size());
      std::transform(s.begin(), s.end(), values.begin(), [c](const BoardSample& b) { return b.value[c]; });
      map.at(t % width, t / width, c) = static_cast<float>(std::clamp(Median(std::move(values)), 0.0, 1.0));
    }
  }
  *measured_fraction = static_cast<double>(measured) / (static_cast<double>(width) * height);
  return map;
}

}  // namespace

SupportAlbedoEstimate EstimateSupportAlbedo(const render::Scene& scene, const SupportPlane& plane,
                                            const std::vector<SupportAlbedoFrame>& frames,
                                            const SupportAlbedoOptions& options) {
  SupportAlbedoEstimate estimate;
  int map_width = 0, map_height = 0;
  BoardQuad quad;
  if (options.board_texel_m > 0) {
    quad = MakeBoardQuad(plane);
    map_width = std::max(1, static_cast<int>(std::lround(2 * quad.half_x_m / options.board_texel_m)));
    map_height = std::max(1, static_cast<int>(std::lround(2 * quad.half_y_m / options.board_texel_m)));
  }
  const size_t count = options.max_frames > 0 ? std::min(frames.size(), static_cast<size_t>(options.max_frames))
                                              : frames.size();
  std::vector<FrameSamples> measured(count);
  tbb::parallel_for(size_t{0}, count, [&](size_t k) {
    measured[k] = MeasureFrame(scene, plane, frames[k * frames.size() / count], options, map_width, map_height);
  });
  std::vector<double> albedo[3], scales[3];
  std::vector<std::vector<BoardSample>> per_texel(static_cast<size_t>(map_width) * map_height);
  for (FrameSamples& s : measured) {
    const int64_t paper = static_cast<int64_t>(s.paper[0].size());
    if (paper < options.min_paper_pixels) continue;
    // The paper gives this frame's flash scale (and exposure) per channel.
    double scale[3];
    for (int c = 0; c < 3; ++c) scale[c] = Median(std::move(s.paper[c])) / plane.paper_albedo;
    if (!(scale[0] > 0 && scale[1] > 0 && scale[2] > 0)) continue;
    ++estimate.frames_used;
    for (int c = 0; c < 3; ++c) scales[c].push_back(scale[c]);
    estimate.paper_pixels += paper;
    estimate.table_pixels += static_cast<int64_t>(s.table[0].size());
    estimate.board_pixels += static_cast<int64_t>(s.board.size());
    for (int c = 0; c < 3; ++c) {
      for (double v : s.table[c]) albedo[c].push_back(v / scale[c]);
    }
    for (BoardSample b : s.board) {
      for (int c = 0; c < 3; ++c) b.value[c] = static_cast<float>(b.value[c] / scale[c]);
      per_texel[b.texel].push_back(b);
    }
  }
  if (estimate.frames_used > 0) {
    for (int c = 0; c < 3; ++c) estimate.flash_scale[c] = Median(std::move(scales[c]));
  }
  if (map_width > 0 && estimate.frames_used > 0) {
    estimate.board_albedo = BoardAlbedoMap(quad.print_albedo, map_width, map_height, std::move(per_texel), options,
                                           &estimate.board_measured_fraction);
  }
  if (estimate.table_pixels < options.min_table_pixels || albedo[0].empty()) {
    estimate.reason = std::to_string(estimate.frames_used) + " frames with lit paper, " +
                      std::to_string(estimate.table_pixels) + " lit table pixels (need " +
                      std::to_string(options.min_table_pixels) + ")";
    return estimate;
  }
  for (int c = 0; c < 3; ++c) estimate.table_albedo[c] = std::clamp(Median(std::move(albedo[c])), 0.0, 1.0);
  estimate.found = true;
  return estimate;
}

}  // namespace relit::relight
