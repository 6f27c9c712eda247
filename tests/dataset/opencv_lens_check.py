#!/usr/bin/python3
"""Cross-check of Mucosa's lens models against OpenCV (Debian python3-opencv).

Usage: opencv_lens_check.py LENS_POINTS WORK_DIR

LENS_POINTS is the test tool tests/dataset/lens_points.cpp: it reads a lens
JSON file (docs/datasets.md, "Lens models") and 3-D points in the camera's
frame from stdin, and prints Mucosa's dataset::project of each. For random
points in front of the camera, the pixels must match OpenCV's to 1e-6 px:
  - "fisheye" lenses (Kannala-Brandt k1..k4) against cv2.fisheye.projectPoints;
  - "pinhole" lenses with Brown k1, k2 against cv2.projectPoints with
    distortion (k1, k2, 0, 0).
Both share Mucosa's conventions: OpenCV camera axes (x right, y down, z
forward), the top-left pixel's centre at (0, 0). Points are drawn inside each
model's one-to-one field (OpenCV does not check it). Exits non-zero on any
mismatch; a missing module is a failure, not a skip.
"""
import json
import math
import os
import shutil
import subprocess
import sys

import cv2
import numpy as np

TOLERANCE_PX = 1e-6

LENSES = [
    # name, lens JSON, largest angle from the axis to draw points at (degrees)
    ("fisheye_4k", {"model": "fisheye", "width": 640, "height": 480, "fx": 250.0, "fy": 252.5, "cx": 322.3,
                    "cy": 237.9, "k1": 0.05, "k2": -0.012, "k3": 0.003, "k4": -0.0004}, 85.0),
    ("fisheye_c3vd_like", {"model": "fisheye", "width": 1350, "height": 1080, "fx": 790.5, "fy": 788.1, "cx": 676.2,
                           "cy": 539.4, "k1": -0.0382, "k2": 0.0107, "k3": -0.0051, "k4": 0.0009}, 80.0),
    ("fisheye_equidistant", {"model": "fisheye", "width": 640, "height": 480, "fx": 229.2, "fy": 229.2,
                             "cx": 319.5, "cy": 239.5}, 89.0),
    ("pinhole_barrel", {"model": "pinhole", "width": 640, "height": 480, "fx": 500.0, "fy": 505.0, "cx": 321.25,
                        "cy": 238.75, "k1": -0.21, "k2": 0.045}, 55.0),
    ("pinhole_pincushion", {"model": "pinhole", "width": 400, "height": 300, "fx": 330.0, "fy": 325.0,
                            "cx": 199.5, "cy": 151.0, "k1": 0.12, "k2": 0.01}, 45.0),
]


def random_points(rng, max_angle_deg, n=500):
    """Points at random directions up to max_angle_deg off the axis, 1 to 200 mm away."""
    theta = np.radians(max_angle_deg) * np.sqrt(rng.uniform(0.0, 1.0, n))
    phi = rng.uniform(0.0, 2.0 * math.pi, n)
    dist = rng.uniform(1.0, 200.0, n)
    pts = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)
    return pts * dist[:, None]


def mucosa_project(tool, lens_path, points):
    text = "".join(f"{p[0]!r} {p[1]!r} {p[2]!r}\n" for p in points)
    r = subprocess.run([tool, lens_path], input=text, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"FAIL: lens_points {lens_path} exited {r.returncode}: {r.stderr.strip()}")
    out = []
    for line in r.stdout.splitlines():
        out.append(None if line == "none" else [float(v) for v in line.split()])
    if len(out) != len(points):
        sys.exit(f"FAIL: lens_points printed {len(out)} lines for {len(points)} points")
    return out


def opencv_project(lens, points):
    K = np.array([[lens["fx"], 0.0, lens["cx"]], [0.0, lens["fy"], lens["cy"]], [0.0, 0.0, 1.0]])
    rvec = np.zeros((3, 1))
    tvec = np.zeros((3, 1))
    if lens["model"] == "fisheye":
        D = np.array([lens.get(k, 0.0) for k in ("k1", "k2", "k3", "k4")], dtype=np.float64)
        px, _ = cv2.fisheye.projectPoints(points.reshape(1, -1, 3), rvec, tvec, K, D)
    else:
        D = np.array([lens.get("k1", 0.0), lens.get("k2", 0.0), 0.0, 0.0], dtype=np.float64)
        px, _ = cv2.projectPoints(points.reshape(-1, 1, 3), rvec, tvec, K, D)
    return px.reshape(-1, 2)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    tool, work = sys.argv[1], sys.argv[2]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    rng = np.random.default_rng(17)
    failures = []
    worst = 0.0
    count = 0
    for name, lens, max_angle in LENSES:
        path = os.path.join(work, name + ".json")
        with open(path, "w") as f:
            json.dump(lens, f, indent=1)
        points = random_points(rng, max_angle)
        mine = mucosa_project(tool, path, points)
        theirs = opencv_project(lens, points)
        missing = sum(1 for m in mine if m is None)
        if missing:
            failures.append(f"{name}: Mucosa has no pixel for {missing} points inside the field")
            continue
        err = float(np.max(np.abs(np.array(mine) - theirs)))
        worst = max(worst, err)
        count += len(points)
        print(f"{name}: {len(points)} points, worst difference {err:.3g} px")
        if not err <= TOLERANCE_PX:
            failures.append(f"{name}: off by {err:.3g} px")
    for f in failures:
        print("FAIL:", f)
    print(f"{count} projections compared with OpenCV {cv2.__version__}; worst difference {worst:.3g} px "
          f"(tolerance {TOLERANCE_PX} px)")
    sys.exit(1 if failures or count == 0 else 0)
