#include "capture/frame_select.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace relit::capture {

FrameScore ScoreFrame(const cv::Mat& grey, const cv::Mat& previous, const SelectOptions& o) {
  RELIT_CHECK(grey.type() == CV_8UC1 && !grey.empty());
  FrameScore score;
  cv::Mat value, laplacian;
  grey.convertTo(value, CV_32F, 1.0 / 255.0);
  cv::Laplacian(value, laplacian, CV_32F, 3);
  cv::Scalar mean, stddev;
  cv::meanStdDev(laplacian, mean, stddev);
  score.sharpness = stddev[0] * stddev[0];
  const double pixels = static_cast<double>(grey.total());
  const int clip = static_cast<int>(std::ceil(o.clip_level * 255.0 - 1e-9));
  const int dark = static_cast<int>(std::floor(o.dark_level * 255.0 + 1e-9));
  score.clipped_fraction = cv::countNonZero(grey >= clip) / pixels;
  score.dark_fraction = cv::countNonZero(grey <= dark) / pixels;
  if (!previous.empty() && previous.size() == grey.size()) {
    score.diff_to_previous = cv::norm(grey, previous, cv::NORM_L1) / (pixels * 255.0);
  }
  return score;
}

void RejectBadFrames(std::vector<Candidate>* candidates, const SelectOptions& o) {
  std::vector<Candidate>& c = *candidates;
  const int n = static_cast<int>(c.size());
  for (int i = 0; i < n; ++i) {
    const FrameScore& s = c[i].score;
    const bool same_time = i > 0 && c[i].source_time_s <= c[i - 1].source_time_s;
    if (same_time || (s.diff_to_previous >= 0 && s.diff_to_previous <= o.duplicate_max_diff)) {
      c[i].rejection = kDuplicate;
    } else if (s.dark_fraction > o.max_dark_fraction) {
      c[i].rejection = kDark;
    } else if (s.clipped_fraction > o.max_clipped_fraction) {
      c[i].rejection = kClipped;
    }
  }
  // Sharpness varies with content, so each frame is compared with its
  // neighbours rather than with a fixed threshold.
  std::vector<double> window;
  for (int i = 0; i < n; ++i) {
    if (c[i].rejection == kDuplicate) continue;
    window.clear();
    for (int j = std::max(0, i - o.blur_window_frames);
         j <= std::min(n - 1, i + o.blur_window_frames); ++j) {
      if (j != i && c[j].rejection != kDuplicate) window.push_back(c[j].score.sharpness);
    }
    if (window.empty()) continue;
    std::nth_element(window.begin(), window.begin() + window.size() / 2, window.end());
    double median = window[window.size() / 2];
    if (window.size() % 2 == 0) {
      median = 0.5 * (median + *std::max_element(window.begin(), window.begin() + window.size() / 2));
    }
    c[i].blur_ratio = median > 0 ? c[i].score.sharpness / median : 1.0;
    if (c[i].rejection.empty() && c[i].blur_ratio < o.min_blur_ratio) c[i].rejection = kBlurred;
  }
}

void Subsample(std::vector<Candidate>* candidates, const SelectOptions& o) {
  std::vector<int> alive;
  for (int i = 0; i < static_cast<int>(candidates->size()); ++i) {
    if ((*candidates)[i].rejection.empty()) alive.push_back(i);
  }
  if (alive.empty()) return;
  const double t0 = (*candidates)[alive.front()].time_s;
  const double t1 = (*candidates)[alive.back()].time_s;
  const int target = o.target_frames > 0
                         ? o.target_frames
                         : std::max(1, static_cast<int>(std::floor((t1 - t0) * o.target_fps)) + 1);
  if (static_cast<int>(alive.size()) <= target) return;
  // Bin b covers [t0 + b w, t0 + (b + 1) w); the last frame falls in the last bin.
  const double width = (t1 - t0) / target;
  std::vector<int> best(target, -1);
  for (int i : alive) {
    const Candidate& candidate = (*candidates)[i];
    int bin = width > 0 ? static_cast<int>((candidate.time_s - t0) / width) : 0;
    bin = std::clamp(bin, 0, target - 1);
    if (best[bin] < 0 || candidate.score.sharpness > (*candidates)[best[bin]].score.sharpness) {
      best[bin] = i;
    }
  }
  std::vector<bool> keep(candidates->size(), false);
  for (int i : best) {
    if (i >= 0) keep[i] = true;
  }
  for (int i : alive) {
    if (!keep[i]) (*candidates)[i].rejection = kNotSelected;
  }
}

std::vector<int> ThinByTime(const std::vector<double>& times_s, double min_spacing_s) {
  const int n = static_cast<int>(times_s.size());
  std::vector<int> kept;
  for (int i = 0; i < n; ++i) {
    if (kept.empty() || min_spacing_s <= 0 || i == n - 1 ||
        times_s[i] - times_s[kept.back()] >= min_spacing_s - 1e-9) {
      kept.push_back(i);
    }
  }
  return kept;
}

std::vector<int> LightFramesAround(double t_s, const std::vector<double>& light_times_s,
                                   int per_side) {
  const int n = static_cast<int>(light_times_s.size());
  if (n == 0 || t_s < light_times_s.front() || t_s > light_times_s.back()) return {};
  // First frame at or after t, and the last at or before it.
  const int after = static_cast<int>(
      std::lower_bound(light_times_s.begin(), light_times_s.end(), t_s) - light_times_s.begin());
  const int before = light_times_s[after] == t_s ? after : after - 1;
  std::vector<int> frames;
  for (int i = std::max(0, before - per_side + 1); i <= std::min(n - 1, after + per_side - 1); ++i) {
    frames.push_back(i);
  }
  return frames;
}

}  // namespace relit::capture
