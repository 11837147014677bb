// Chart packing (bitmap first-fit with gutters) and atlas validation.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <spdlog/spdlog.h>

#include "reconstruct/atlas_internal.h"
#include "reconstruct/uv_atlas.h"

namespace relit::reconstruct {
namespace {

// A bitmap with rows of 64-bit words (one spare zero word per row).
struct Bitmap {
  int width = 0, height = 0, words = 0;
  std::vector<uint64_t> bits;
  Bitmap(int w, int h) : width(w), height(h), words((w + 63) / 64 + 1), bits(static_cast<size_t>(words) * h, 0) {}
  void Set(int x, int y) { bits[static_cast<size_t>(y) * words + (x >> 6)] |= uint64_t{1} << (x & 63); }
  bool Get(int x, int y) const { return (bits[static_cast<size_t>(y) * words + (x >> 6)] >> (x & 63)) & 1; }
  // 64 bits starting at bit x of row y.
  uint64_t Window(int x, int y) const {
    const uint64_t* row = &bits[static_cast<size_t>(y) * words];
    const int q = x >> 6, r = x & 63;
    return r == 0 ? row[q] : (row[q] >> r) | (row[q + 1] << (64 - r));
  }
};

double Cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

double PointTriangleDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                             const Eigen::Vector2d& c) {
  const double s = Cross2(b - a, c - a) >= 0 ? 1.0 : -1.0;
  if (s * Cross2(b - a, p - a) >= 0 && s * Cross2(c - b, p - b) >= 0 && s * Cross2(a - c, p - c) >= 0) return 0;
  auto seg = [&](const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
    const Eigen::Vector2d d = v - u;
    const double t = std::clamp((p - u).dot(d) / std::max(d.squaredNorm(), 1e-300), 0.0, 1.0);
    return (u + t * d - p).norm();
  };
  return std::min({seg(a, b), seg(b, c), seg(c, a)});
}

// Conservative raster of triangles (texel coordinates) into a bitmap.
void RasterConservative(const std::vector<std::array<Eigen::Vector2d, 3>>& tris, Bitmap* bitmap) {
  for (const auto& t : tris) {
    const Eigen::Vector2d lo = t[0].cwiseMin(t[1]).cwiseMin(t[2]), hi = t[0].cwiseMax(t[1]).cwiseMax(t[2]);
    for (int y = std::max(0, static_cast<int>(std::floor(lo.y())) - 1);
         y <= std::min(bitmap->height - 1, static_cast<int>(hi.y()) + 1); ++y) {
      for (int x = std::max(0, static_cast<int>(std::floor(lo.x())) - 1);
           x <= std::min(bitmap->width - 1, static_cast<int>(hi.x()) + 1); ++x) {
        if (PointTriangleDistance({x + 0.5, y + 0.5}, t[0], t[1], t[2]) <= 0.7072) bitmap->Set(x, y);
      }
    }
  }
}

struct Footprint {
  int chart = 0;
  double angle = 0;
  Eigen::Vector2d lo, hi;  // rotated chart bounds, metres
};

bool TryPack(const std::vector<atlas::Chart>& charts, const std::vector<Footprint>& prints, int resolution,
             int gutter, double scale, std::vector<Eigen::Vector2i>* offsets) {
  Bitmap blocked(resolution, resolution);
  offsets->assign(charts.size(), Eigen::Vector2i::Zero());
  for (const Footprint& fp : prints) {
    const atlas::Chart& chart = charts[fp.chart];
    const int w = static_cast<int>(std::ceil((fp.hi.x() - fp.lo.x()) * scale)) + 2;
    const int h = static_cast<int>(std::ceil((fp.hi.y() - fp.lo.y()) * scale)) + 2;
    if (w > resolution || h > resolution) return false;
    const Eigen::Rotation2Dd rotation(fp.angle);
    std::vector<std::array<Eigen::Vector2d, 3>> tris;
    for (const Eigen::Vector3i& t : chart.triangles) {
      std::array<Eigen::Vector2d, 3> p;
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector2d r = rotation * chart.uv[t[k]];
        p[k] = Eigen::Vector2d((r.x() - fp.lo.x()) * scale + 1.0, (fp.hi.y() - r.y()) * scale + 1.0);
      }
      tris.push_back(p);
    }
    Bitmap mask(w, h);
    RasterConservative(tris, &mask);
    bool placed = false;
    for (int y = 0; y + h <= resolution && !placed; ++y) {
      for (int x = 0; x + w <= resolution && !placed; ++x) {
        bool free = true;
        for (int r = 0; r < h && free; ++r) {
          for (int k = 0; k < mask.words - 1 && free; ++k) {
            if (mask.bits[static_cast<size_t>(r) * mask.words + k] & blocked.Window(x + 64 * k, y + r)) free = false;
          }
        }
        if (!free) continue;
        placed = true;
        (*offsets)[fp.chart] = {x, y};
        for (int r = 0; r < h; ++r) {
          for (int c = 0; c < w; ++c) {
            if (!mask.Get(c, r)) continue;
            for (int dy = -gutter; dy <= gutter; ++dy) {
              for (int dx = -gutter; dx <= gutter; ++dx) {
                const int X = x + c + dx, Y = y + r + dy;
                if (X >= 0 && Y >= 0 && X < resolution && Y < resolution) blocked.Set(X, Y);
              }
            }
          }
        }
      }
    }
    if (!placed) return false;
  }
  return true;
}

}  // namespace

namespace atlas {

bool PackCharts(std::vector<Chart>* charts, int resolution, int gutter, double* texels_per_metre) {
  // Rotate every chart to its smallest bounding rectangle, landscape.
  std::vector<Footprint> prints;
  double total_area = 0;
  for (std::size_t i = 0; i < charts->size(); ++i) {
    Footprint best;
    best.chart = static_cast<int>(i);
    double best_area = 1e300;
    for (int a = 0; a < 36; ++a) {
      const double angle = a * M_PI / 72.0;
      const Eigen::Rotation2Dd rotation(angle);
      Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e300), hi = -lo;
      for (const Eigen::Vector2d& uv : (*charts)[i].uv) {
        const Eigen::Vector2d r = rotation * uv;
        lo = lo.cwiseMin(r);
        hi = hi.cwiseMax(r);
      }
      const double area = (hi - lo).prod();
      if (area < best_area * 0.999) {
        best_area = area;
        best.angle = (hi - lo).y() > (hi - lo).x() ? angle + M_PI / 2 : angle;
      }
    }
    const Eigen::Rotation2Dd rotation(best.angle);
    best.lo = Eigen::Vector2d::Constant(1e300);
    best.hi = -best.lo;
    for (const Eigen::Vector2d& uv : (*charts)[i].uv) {
      best.lo = best.lo.cwiseMin(rotation * uv);
      best.hi = best.hi.cwiseMax(rotation * uv);
    }
    total_area += best_area;
    prints.push_back(best);
  }
  std::sort(prints.begin(), prints.end(), [](const Footprint& a, const Footprint& b) {
    return (a.hi.y() - a.lo.y()) > (b.hi.y() - b.lo.y());
  });
  std::vector<Eigen::Vector2i> offsets, best_offsets;
  double fit = 0, scale = std::sqrt(0.9 * resolution * resolution / std::max(total_area, 1e-300));
  for (int attempt = 0; attempt < 60 && fit == 0; ++attempt, scale *= 0.92) {
    if (TryPack(*charts, prints, resolution, gutter, scale, &offsets)) {
      fit = scale;
      best_offsets = offsets;
    }
  }
  if (fit == 0) return false;
  // Refine between the fitting scale and the failed one above it.
  double lo = fit, hi = fit / 0.92;
  for (int i = 0; i < 4; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (TryPack(*charts, prints, resolution, gutter, mid, &offsets)) {
      lo = mid;
      best_offsets = offsets;
    } else {
      hi = mid;
    }
  }
  *texels_per_metre = lo;
  for (const Footprint& fp : prints) {
    Chart& chart = (*charts)[fp.chart];
    const Eigen::Rotation2Dd rotation(fp.angle);
    const Eigen::Vector2i& o = best_offsets[fp.chart];
    for (Eigen::Vector2d& uv : chart.uv) {
      const Eigen::Vector2d r = rotation * uv;
      const double X = o.x() + (r.x() - fp.lo.x()) * lo + 1.0;
      const double Y = o.y() + (fp.hi.y() - r.y()) * lo + 1.0;
      uv = Eigen::Vector2d(X / resolution, 1.0 - Y / resolution);
    }
  }
  return true;
}

}  // namespace atlas

AtlasStats MeasureAtlas(const render::TriangleMesh& mesh, const UvAtlas& atlas) {
  AtlasStats s;
  s.charts = atlas.chart_count;
  const int R = atlas.resolution_px;
  const int n = static_cast<int>(mesh.triangles.size());
  std::vector<uint8_t> cover(static_cast<size_t>(R) * R, 0);
  std::vector<int> owner(static_cast<size_t>(R) * R, -1);
  double area3d_total = 0, area_uv_total = 0;
  std::vector<double> area3d(n), area_uv(n);
  for (int f = 0; f < n; ++f) {
    std::array<Eigen::Vector2d, 3> p;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2f& uv = atlas.corner_uvs[3 * f + k];
      p[k] = Eigen::Vector2d(uv.x() * R, (1.0 - uv.y()) * R);  // texel space, y down
    }
    const double signed_uv = -0.5 * Cross2(p[1] - p[0], p[2] - p[0]);  // v-up orientation
    const Eigen::Vector3i& t = mesh.triangles[f];
    area3d[f] = 0.5 * (mesh.positions[t[1]] - mesh.positions[t[0]])
                          .cross(mesh.positions[t[2]] - mesh.positions[t[0]]).cast<double>().norm();
    area_uv[f] = std::abs(signed_uv);
    area3d_total += area3d[f];
    area_uv_total += area_uv[f];
    if (std::abs(signed_uv) < 1e-9) {
      ++s.degenerate_triangles;
      continue;
    }
    if (signed_uv < 0) ++s.flipped_triangles;
    const Eigen::Vector2d lo = p[0].cwiseMin(p[1]).cwiseMin(p[2]), hi = p[0].cwiseMax(p[1]).cwiseMax(p[2]);
    const double sign = signed_uv > 0 ? -1.0 : 1.0;  // texel-space orientation
    for (int y = std::max(0, static_cast<int>(lo.y()) - 1); y <= std::min(R - 1, static_cast<int>(hi.y()) + 1); ++y) {
      for (int x = std::max(0, static_cast<int>(lo.x()) - 1); x <= std::min(R - 1, static_cast<int>(hi.x()) + 1); ++x) {
        const Eigen::Vector2d c(x + 0.5, y + 0.5);
        const size_t i = static_cast<size_t>(y) * R + x;
        if (sign * Cross2(p[1] - p[0], c - p[0]) > 0 && sign * Cross2(p[2] - p[1], c - p[1]) > 0 &&
            sign * Cross2(p[0] - p[2], c - p[2]) > 0) {
          if (cover[i] == 1) ++s.overlapping_texels;
          cover[i] = static_cast<uint8_t>(std::min(cover[i] + 1, 2));
        }
        if (PointTriangleDistance(c, p[0], p[1], p[2]) <= 0.7072) {
          if (owner[i] >= 0 && owner[i] != atlas.face_chart[f]) ++s.chart_contact_texels;
          owner[i] = atlas.face_chart[f];
        }
      }
    }
  }
  size_t covered = 0;
  for (uint8_t c : cover) covered += c > 0;
  s.utilisation = static_cast<double>(covered) / (static_cast<double>(R) * R);
  // Smallest Chebyshev gap between conservative footprints of different charts.
  const int g = atlas.gutter_px + 1;
  s.min_chart_gap_texels = g;
  for (int y = 0; y < R; ++y) {
    for (int x = 0; x < R; ++x) {
      const int c = owner[static_cast<size_t>(y) * R + x];
      if (c < 0) continue;
      for (int dy = -g; dy <= g; ++dy) {
        for (int dx = -g; dx <= g; ++dx) {
          const int X = x + dx, Y = y + dy;
          if (X < 0 || Y < 0 || X >= R || Y >= R) continue;
          const int o = owner[static_cast<size_t>(Y) * R + X];
          if (o >= 0 && o != c) s.min_chart_gap_texels = std::min(s.min_chart_gap_texels, std::max(std::abs(dx), std::abs(dy)) - 1);
        }
      }
    }
  }
  // Stretch relative to the atlas' mean texel density.
  const double density = std::sqrt(area_uv_total / std::max(area3d_total, 1e-300));
  s.texels_per_metre = density;
  double l2_sum = 0;
  std::vector<double> ratios;
  for (int f = 0; f < n; ++f) {
    if (area_uv[f] < 1e-9 || area3d[f] <= 0) continue;
    std::array<Eigen::Vector2d, 3> q;
    for (int k = 0; k < 3; ++k) q[k] = atlas.corner_uvs[3 * f + k].cast<double>() * (R / density);
    const Eigen::Vector3i& t = mesh.triangles[f];
    const Eigen::Vector3d p1 = mesh.positions[t[0]].cast<double>(), p2 = mesh.positions[t[1]].cast<double>(),
                          p3 = mesh.positions[t[2]].cast<double>();
    const double two_a = Cross2(q[1] - q[0], q[2] - q[0]);
    const Eigen::Vector3d ss = (p1 * (q[1].y() - q[2].y()) + p2 * (q[2].y() - q[0].y()) + p3 * (q[0].y() - q[1].y())) / two_a;
    const Eigen::Vector3d st = (p1 * (q[2].x() - q[1].x()) + p2 * (q[0].x() - q[2].x()) + p3 * (q[1].x() - q[0].x())) / two_a;
    const double l2 = std::sqrt(0.5 * (ss.squaredNorm() + st.squaredNorm()));
    l2_sum += l2 * l2 * area3d[f];
    s.stretch_l2_max = std::max(s.stretch_l2_max, l2);
    const double r = area_uv[f] / (area3d[f] * density * density);
    ratios.push_back(std::max(r, 1.0 / r));
  }
  s.stretch_l2_mean = std::sqrt(l2_sum / std::max(area3d_total, 1e-300));
  if (!ratios.empty()) {
    std::sort(ratios.begin(), ratios.end());
    s.stretch_area_ratio_p95 = ratios[static_cast<size_t>(0.95 * (ratios.size() - 1))];
  }
  return s;
}

Image AtlasPreview(const render::TriangleMesh& mesh, const UvAtlas& atlas) {
  const int R = atlas.resolution_px;
  Image image(R, R, 3, 0.0f);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    uint32_t h = static_cast<uint32_t>(atlas.face_chart[f]) * 2654435761u;
    const float colour[3] = {0.35f + 0.6f * ((h >> 8) & 255) / 255.0f, 0.35f + 0.6f * ((h >> 16) & 255) / 255.0f,
                             0.35f + 0.6f * ((h >> 24) & 255) / 255.0f};
    std::array<Eigen::Vector2d, 3> p;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2f& uv = atlas.corner_uvs[3 * f + k];
      p[k] = Eigen::Vector2d(uv.x() * R, (1.0 - uv.y()) * R);
    }
    const Eigen::Vector2d lo = p[0].cwiseMin(p[1]).cwiseMin(p[2]), hi = p[0].cwiseMax(p[1]).cwiseMax(p[2]);
    for (int y = std::max(0, static_cast<int>(lo.y())); y <= std::min(R - 1, static_cast<int>(hi.y())); ++y) {
      for (int x = std::max(0, static_cast<int>(lo.x())); x <= std::min(R - 1, static_cast<int>(hi.x())); ++x) {
        const double d = PointTriangleDistance({x + 0.5, y + 0.5}, p[0], p[1], p[2]);
        if (d > 0.5) continue;
        const bool edge = d > 0 || std::abs(Cross2(p[1] - p[0], Eigen::Vector2d(x + 0.5, y + 0.5) - p[0])) /
                                           (p[1] - p[0]).norm() < 0.5;
        for (int c = 0; c < 3; ++c) image.at(x, y, c) = edge ? 0.6f * colour[c] : colour[c];
      }
    }
  }
  return image;
}

}  // namespace relit::reconstruct
