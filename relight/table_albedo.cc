#include "relight/table_albedo.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <tbb/parallel_for.h>

#include "core/image.h"
#include "core/median.h"

namespace relit::relight {

namespace {

using render::Vec3f;

enum class PlanePart { kNone, kPaper, kTable };

// What the ray through pixel (x, y) of `camera` sees first: white paper
// (all four neighbouring rays too, so no pixel straddles the print), the
// table, or something else (the object, ink, nothing).
PlanePart SeenPart(const render::Scene& scene, const SupportPlane& plane, const Camera& camera, double x, double y,
                   render::Hit* hit) {
  const Vec3f origin = camera.Center().cast<float>();
  auto trace = [&](double px, double py, render::Hit* h) {
    const Vec3f direction = camera.PixelToWorldRay({px, py}).cast<float>();
    return scene.Intersect(origin, direction, 1e-4f, 1e4f, h);
  };
  if (!trace(x, y, hit)) return PlanePart::kNone;
  if (hit->object_id == kSupportTableObjectId) return PlanePart::kTable;
  if (hit->object_id != kSupportBoardObjectId) return PlanePart::kNone;
  const float paper_threshold = static_cast<float>(0.5 * (plane.paper_albedo + plane.ink_albedo));
  auto is_paper = [&](const render::Hit& h) {
    return h.object_id == kSupportBoardObjectId &&
           scene.material(h.material).At(h.uv).diffuse.x() > paper_threshold;
  };
  if (!is_paper(*hit)) return PlanePart::kNone;
  for (const auto& [dx, dy] : std::array<std::pair<double, double>, 4>{{{-1, 0}, {1, 0}, {0, -1}, {0, 1}}}) {
    render::Hit neighbour;
    if (!trace(x + dx, y + dy, &neighbour) || !is_paper(neighbour)) return PlanePart::kNone;
  }
  return PlanePart::kPaper;
}

struct FrameSamples {
  std::vector<double> paper[3], table[3];  // radiance / (cos / (pi r^2)) per channel
};

FrameSamples MeasureFrame(const render::Scene& scene, const SupportPlane& plane, const TableAlbedoFrame& frame,
                          const TableAlbedoOptions& options) {
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
      auto& target = part == PlanePart::kPaper ? samples.paper : samples.table;
      for (int c = 0; c < 3; ++c) target[c].push_back(radiance[c] / irradiance);
    }
  }
  return samples;
}

}  // namespace

TableAlbedoEstimate EstimateTableAlbedo(const render::Scene& scene, const SupportPlane& plane,
                                        const std::vector<TableAlbedoFrame>& frames,
                                        const TableAlbedoOptions& options) {
  TableAlbedoEstimate estimate;
  const size_t count = options.max_frames > 0 ? std::min(frames.size(), static_cast<size_t>(options.max_frames))
                                              : frames.size();
  std::vector<FrameSamples> measured(count);
  tbb::parallel_for(size_t{0}, count, [&](size_t k) {
    measured[k] = MeasureFrame(scene, plane, frames[k * frames.size() / count], options);
  });
  std::vector<double> albedo[3];
  for (FrameSamples& s : measured) {
    const int64_t paper = static_cast<int64_t>(s.paper[0].size());
    if (paper < options.min_paper_pixels || s.table[0].empty()) continue;
    ++estimate.frames_used;
    estimate.paper_pixels += paper;
    estimate.table_pixels += static_cast<int64_t>(s.table[0].size());
    for (int c = 0; c < 3; ++c) {
      // The paper gives this frame's flash scale (and exposure) per channel.
      const double scale = Median(std::move(s.paper[c])) / plane.paper_albedo;
      if (!(scale > 0)) continue;
      for (double v : s.table[c]) albedo[c].push_back(v / scale);
    }
  }
  if (estimate.table_pixels < options.min_table_pixels || albedo[0].empty() || albedo[1].empty() ||
      albedo[2].empty()) {
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
