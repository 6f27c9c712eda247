#!/usr/bin/python3
"""Cross-check of `mucosa dataset export` against OpenCV (Debian python3-opencv).

Usage: opencv_export_check.py MUCOSA_CLI WORK_DIR

Writes a small synthetic frames.json (two lenses: a pinhole and one with radial
distortion k1, k2; rotations including half turns), exports it with the CLI as
a COLMAP model and as nerfstudio transforms.json (in mm and in metres), reads
the exported files back with each format's documented conventions, and
projects known 3-D points with cv2.projectPoints through each exported camera.
They must land where cv2.projectPoints puts them through the frames file's own
camera (OpenCV's conventions are Mucosa's: x right, y down, z forward, the
top-left pixel's centre at (0, 0)), to 1e-6 px, once COLMAP's and nerfstudio's
half-pixel shift (their top-left pixel centre is (0.5, 0.5)) is taken off.
Exits non-zero on any mismatch; a missing module is a failure, not a skip.
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


def rotation(axis, angle):
    axis = np.asarray(axis, dtype=np.float64)
    R, _ = cv2.Rodrigues(axis / np.linalg.norm(axis) * angle)
    return R


def make_frames(folder):
    """A frames.json in `folder` with 10 frames and two lenses."""
    rng = np.random.default_rng(11)
    pinhole = {"width": 320, "height": 240, "fx": 280.0, "fy": 290.0, "cx": 161.5, "cy": 118.25}
    distorted = {"width": 400, "height": 300, "fx": 330.0, "fy": 325.0, "cx": 199.5, "cy": 151.0,
                 "k1": -0.18, "k2": 0.04}
    rotations = [rotation([1, 0, 0], 0.0), rotation([1, 0, 0], math.pi), rotation([0, 1, 0], math.pi),
                 rotation([0, 0, 1], math.pi), rotation([1, 2, 3], 2.4)]
    while len(rotations) < 10:
        rotations.append(rotation(rng.uniform(-1, 1, 3), rng.uniform(-math.pi, math.pi)))
    frames = []
    for i, R in enumerate(rotations):
        m = np.eye(4)
        m[:3, :3] = R
        m[:3, 3] = rng.uniform(-80, 80, 3)
        frames.append({"image": f"video/frame_{i:04d}.png",
                       "intrinsics": dict(distorted if i % 2 else pinhole),
                       "camera_to_world": m.tolist()})
    path = os.path.join(folder, "frames.json")
    with open(path, "w") as f:
        json.dump({"units": "mm", "frames": frames}, f, indent=1)
    return path, frames


def points_seen_by(frame):
    """World points (mm) in front of the frame's camera."""
    c2w = np.asarray(frame["camera_to_world"])
    pts = []
    for xn in (-0.4, -0.05, 0.0, 0.35):
        for yn in (-0.3, 0.1, 0.38):
            for z in (5.0, 31.0, 120.0):
                pts.append(c2w[:3, :3] @ np.array([xn * z, yn * z, z]) + c2w[:3, 3])
    return np.array(pts)


def project(points, R_wc, t_wc, fx, fy, cx, cy, dist):
    """cv2.projectPoints of world points through a world-to-camera pose."""
    rvec, _ = cv2.Rodrigues(np.asarray(R_wc, dtype=np.float64))
    K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    px, _ = cv2.projectPoints(points.reshape(-1, 1, 3), rvec, np.asarray(t_wc, dtype=np.float64).reshape(3, 1), K,
                              np.asarray(dist, dtype=np.float64))
    return px.reshape(-1, 2)


def mucosa_pixels(frame, points):
    """Where the frames file's own camera puts `points` (OpenCV = Mucosa conventions)."""
    c2w = np.asarray(frame["camera_to_world"])
    R = c2w[:3, :3].T
    t = -R @ c2w[:3, 3]
    k = frame["intrinsics"]
    return project(points, R, t, k["fx"], k["fy"], k["cx"], k["cy"], [k.get("k1", 0.0), k.get("k2", 0.0), 0.0, 0.0])


def hamilton(w, x, y, z):
    """Rotation matrix of a Hamilton quaternion (COLMAP's doc/format.rst)."""
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def run_cli(cli, *args):
    r = subprocess.run([cli, *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"FAIL: mucosa {' '.join(args)} exited {r.returncode}: {r.stderr.strip()}")


class Checker:
    def __init__(self):
        self.worst = 0.0
        self.count = 0
        self.failures = []

    def compare(self, what, got, want):
        err = float(np.max(np.abs(got - want)))
        self.worst = max(self.worst, err)
        self.count += len(got)
        if not err <= TOLERANCE_PX:
            self.failures.append(f"{what}: off by {err:.3g} px")


def check_colmap(folder, frames, checker):
    cameras = {}
    with open(os.path.join(folder, "cameras.txt")) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            w = line.split()
            cameras[int(w[0])] = (w[1], [float(v) for v in w[4:]])
    with open(os.path.join(folder, "images.txt")) as f:
        lines = [l.rstrip("\n") for l in f if not l.startswith("#")]
    images = lines[0::2]
    if len(images) != len(frames) or any(l != "" for l in lines[1::2]):
        checker.failures.append("colmap: images.txt is not one pose line and one empty points line per frame")
        return
    for i, (line, frame) in enumerate(zip(images, frames)):
        w = line.split()
        R = hamilton(*[float(v) for v in w[1:5]])
        t = np.array([float(v) for v in w[5:8]])
        model, p = cameras[int(w[8])]
        if model == "PINHOLE":
            dist = [0.0, 0.0, 0.0, 0.0]
        elif model == "OPENCV":  # fx fy cx cy k1 k2 p1 p2: OpenCV's own distortion terms
            dist = p[4:8]
        else:
            checker.failures.append(f"colmap: unexpected model {model}")
            continue
        pts = points_seen_by(frame)
        got = project(pts, R, t, p[0], p[1], p[2], p[3], dist) - 0.5
        checker.compare(f"colmap frame {i} ({model})", got, mucosa_pixels(frame, pts))


def check_nerfstudio(path, frames_path, frames, scale, checker):
    with open(path) as f:
        j = json.load(f)
    if j.get("camera_model") != "OPENCV":
        checker.failures.append(f"nerfstudio: camera_model {j.get('camera_model')}")
        return
    base = os.path.dirname(path)
    for i, (fr, frame) in enumerate(zip(j["frames"], frames)):
        k = {key: fr.get(key, j.get(key)) for key in ("fl_x", "fl_y", "cx", "cy", "k1", "k2", "k3", "k4", "p1", "p2")}
        if k["k4"] != 0:
            checker.failures.append("nerfstudio: k4 (an r^8 term) has no OpenCV equivalent")
            continue
        want_image = os.path.normpath(os.path.join(os.path.dirname(frames_path), frame["image"]))
        if os.path.normpath(os.path.join(base, fr["file_path"])) != want_image:
            checker.failures.append(f"nerfstudio frame {i}: file_path {fr['file_path']} is not {want_image}")
        M = np.asarray(fr["transform_matrix"], dtype=np.float64)
        c2w = M.copy()
        c2w[:3, 1:3] *= -1  # nerfstudio's OpenGL camera axes (y up, z back) back to OpenCV's
        R = c2w[:3, :3].T
        t = -R @ c2w[:3, 3]
        pts = points_seen_by(frame)
        got = project(pts * scale, R, t, k["fl_x"], k["fl_y"], k["cx"], k["cy"],
                      [k["k1"], k["k2"], k["p1"], k["p2"], k["k3"]]) - 0.5
        checker.compare(f"nerfstudio frame {i} (scale {scale})", got, mucosa_pixels(frame, pts))


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    cli, work = sys.argv[1], sys.argv[2]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    frames_path, frames = make_frames(work)
    checker = Checker()

    run_cli(cli, "dataset", "export", frames_path, "--format", "colmap", "-o", os.path.join(work, "sparse"))
    check_colmap(os.path.join(work, "sparse"), frames, checker)

    os.makedirs(os.path.join(work, "ns"))
    for scale, name in ((1.0, "transforms_mm.json"), (0.001, "transforms_m.json")):
        out = os.path.join(work, "ns", name)
        run_cli(cli, "dataset", "export", frames_path, "--format", "nerfstudio", "-o", out, "--scale", repr(scale))
        check_nerfstudio(out, frames_path, frames, scale, checker)

    for f in checker.failures:
        print("FAIL:", f)
    print(f"{checker.count} projections compared with cv2.projectPoints; worst difference {checker.worst:.3g} px "
          f"(tolerance {TOLERANCE_PX} px)")
    sys.exit(1 if checker.failures or checker.count == 0 else 0)
