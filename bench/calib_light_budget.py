#!/usr/bin/env python3
"""Flash interpolation error of capture's phone L frame selections (issue 28).

A benchmark, not a test (docs/notes/calib-at-scale-2026-11-27.md). From a
relit-synth truth.json (`--truth-only` is enough: nothing is rendered), for
N phone V frames kept evenly over the time both phones record:

- selects phone L frames as relit-capture does (`light_frames_per_side` on
  each side of every kept phone V frame, among the phone L frames at least
  `light_min_spacing_s` apart: capture/frame_select.cc ThinByTime and
  LightFramesAround), with the true phone L flash positions (no calibration
  error);
- interpolates the flash at each phone V time as calib does
  (calib/lights.cc InterpolateLights: cubic through two frames on each side
  within 3 x max_gap_s of their inner neighbour, else linear; reliable when
  the nearest is within max_gap_s and the two around within 2 x max_gap_s);
- prints phone L frames kept and the distance to the true flash position at
  the phone V time (median / p90 / max, mm) and the unreliable count.

Usage: bench/calib_light_budget.py S/truth.json [N ...]   (default N: 400 100)
"""
import bisect
import json
import math
import sys

MAX_GAP_S = 0.05  # calib's light.max_gap_s


def thin_by_time(times, spacing):
    kept = []
    for i, t in enumerate(times):
        if not kept or spacing <= 0 or i == len(times) - 1 or t - times[kept[-1]] >= spacing - 1e-9:
            kept.append(i)
    return kept


def frames_around(t, times, per_side):
    if not times or t < times[0] or t > times[-1]:
        return []
    after = bisect.bisect_left(times, t)
    before = after if times[after] == t else after - 1
    return list(range(max(0, before - per_side + 1), min(len(times) - 1, after + per_side - 1) + 1))


def lagrange(ts, values, t):
    out = [0.0, 0.0, 0.0]
    for i, ti in enumerate(ts):
        w = 1.0
        for j, tj in enumerate(ts):
            if j != i:
                w *= (t - tj) / (ti - tj)
        out = [o + w * v for o, v in zip(out, values[i])]
    return out


def interpolate(times, flashes, t):
    after = bisect.bisect_right(times, t)
    before = after - 1
    if before < 0 or after >= len(times):
        return None, False
    lo, hi = before, after
    if lo - 1 >= 0 and times[lo] - times[lo - 1] <= 3 * MAX_GAP_S:
        lo -= 1
    if hi + 1 < len(times) and times[hi + 1] - times[hi] <= 3 * MAX_GAP_S:
        hi += 1
    if hi - lo + 1 == 3:
        lo, hi = before, after
    gap = min(t - times[before], times[after] - t)
    reliable = gap <= MAX_GAP_S and times[after] - times[before] <= 2 * MAX_GAP_S + 1e-9
    return lagrange(times[lo:hi + 1], flashes[lo:hi + 1], t), reliable


def main():
    truth = json.load(open(sys.argv[1]))
    counts = [int(a) for a in sys.argv[2:]] or [400, 100]
    view = truth["videos"]["view"]["frames"]
    light = truth["videos"]["light"]["frames"]
    light_t = [f["t_common_s"] for f in light]
    light_flash = [f["light_position_world_m"] for f in light]
    inside = [f for f in view if light_t[0] <= f["t_common_s"] <= light_t[-1]]
    for n in counts:
        t0, t1 = inside[0]["t_common_s"], inside[-1]["t_common_s"]
        bins = {}
        for f in inside:  # synthetic frames are equally sharp: the first of each time bin
            bins.setdefault(min(n - 1, int((f["t_common_s"] - t0) / ((t1 - t0) / n))), f)
        kept_view = [bins[b] for b in sorted(bins)]
        for per_side, spacing in [(2, 0.0), (1, 0.0), (2, 0.06), (2, 0.1)]:
            candidates = thin_by_time(light_t, spacing)
            cand_t = [light_t[i] for i in candidates]
            chosen = sorted({candidates[j] for f in kept_view for j in frames_around(f["t_common_s"], cand_t, per_side)})
            times = [light_t[i] for i in chosen]
            flashes = [light_flash[i] for i in chosen]
            errors, unreliable = [], 0
            for f in kept_view:
                p, reliable = interpolate(times, flashes, f["t_common_s"])
                unreliable += 0 if reliable else 1
                if p is not None:
                    errors.append(math.dist(p, f["light_position_world_m"]) * 1000)
            errors.sort()
            q = lambda x: errors[min(len(errors) - 1, int(x * len(errors)))]
            print(f"phone V {len(kept_view):4d} | light_frames_per_side {per_side}, light_min_spacing_s {spacing:.2f}: "
                  f"phone L {len(chosen):4d} | flash error median {q(0.5):.3f} p90 {q(0.9):.3f} max {errors[-1]:.3f} mm"
                  f" | unreliable {unreliable}")


if __name__ == "__main__":
    main()
