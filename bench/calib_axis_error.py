#!/usr/bin/env python3
"""Camera-centre error of a calibrated synthetic capture, split along and
across each frame's true optical axis, per device (issue 28).

A benchmark, not a test (docs/notes/calib-at-scale-2026-11-27b.md). A focal
length off by a fraction e moves a board-posed camera along its axis by
about -e times its distance (the board's image size is f / distance); a
rotation error moves it across. Reads W/calib/cameras.json, W/capture/
capture.json (frame name -> source frame) and the truth.json of relit-synth.

Usage: bench/calib_axis_error.py W S/truth.json
"""
import json
import math
import statistics as st
import sys


def rotation(q):
    w, x, y, z = q
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]


def centre(cam_from_world):
    r = rotation(cam_from_world["rotation_wxyz"])
    t = cam_from_world["translation_m"]
    return [-sum(r[i][j] * t[i] for i in range(3)) for j in range(3)], r


def main(workspace, truth_path):
    cameras = json.load(open(workspace + "/calib/cameras.json"))
    capture = json.load(open(workspace + "/capture/capture.json"))
    truth = json.load(open(truth_path))
    rows = {}
    for f in cameras["frames"]:
        device, index = f["name"].split("/")
        source = capture[device + "_frames"][int(index)]["source_frame"]
        estimated, _ = centre(f["cam_from_world"])
        true, r = centre(truth["videos"][device]["frames"][source]["cam_from_world"])
        d = [estimated[i] - true[i] for i in range(3)]
        in_camera = [sum(r[i][j] * d[j] for j in range(3)) for i in range(3)]
        distance = math.sqrt(sum(c * c for c in true))
        rows.setdefault(device, []).append((math.sqrt(sum(c * c for c in d)) * 1e3, in_camera[2] * 1e3,
                                            math.hypot(in_camera[0], in_camera[1]) * 1e3, distance))
    print("| device | frames | centre error mm | along the axis mm (+ = towards the scene) | "
          "along / distance % | across the axis mm |")
    print("| --- | --- | --- | --- | --- | --- |")
    for device, r in rows.items():
        print(f"| {device} | {len(r)} | {st.median(x[0] for x in r):.2f} | {st.median(x[1] for x in r):+.2f} | "
              f"{st.median(x[1] / x[3] / 10 for x in r):+.3f} | {st.median(x[2] for x in r):.2f} |")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
