#!/usr/bin/python3
"""Ground truth through a lens (dataset::groundTruth with a Lens) checked with OpenCV.

Usage: opencv_lens_truth_check.py LENS_POINTS WORK_DIR

LENS_POINTS is the test tool tests/dataset/lens_points.cpp; with --truth it
prints, for every pixel that sees a surface, the triangle, the barycentrics
b1, b2 and the planar depth. The mesh is a bumpy, curving tube written here
as OBJ (numpy, independently of Mucosa), seen from inside through
  - a Kannala-Brandt fisheye (k1..k4) and an equidistant one, against
    cv2.fisheye.projectPoints / cv2.fisheye.undistortPoints;
  - a Brown pinhole (k1, k2), against cv2.projectPoints / cv2.undistortPoints.
For each lens:
  - each pixel's mesh point (b0 A + b1 B + b2 C of the named triangle) is
    projected by OpenCV: it must land on the pixel (0.1 px RMS and worst;
    float barycentrics make it ~1e-5 px), and its z in the camera frame must
    be the planar depth (1e-4 relative);
  - on a sample of pixels, OpenCV's ray for the pixel is intersected with
    every triangle (Moller-Trumbore, numpy): the nearest must be the named
    triangle (or, at a shared edge, one at the same distance), and pixels
    without a surface must have no hit.
The omnidirectional model has no OpenCV counterpart (cv2.omnidir is Mei's
unified model): it is checked analytically in C++ only (LensTruth tests).
Debian's python3-opencv and python3-numpy; a missing module fails the test.
"""
import json
import os
import subprocess
import sys

import cv2
import numpy as np

from truth_check_common import finish

LENSES = [
    ("fisheye_kb", {"model": "fisheye", "width": 160, "height": 120, "fx": 58.0, "fy": 58.5, "cx": 79.3,
                    "cy": 59.6, "k1": -0.03, "k2": 0.004, "k3": -0.001, "k4": 0.0001}),
    ("fisheye_equidistant", {"model": "fisheye", "width": 160, "height": 120, "fx": 52.0, "fy": 52.0,
                             "cx": 79.5, "cy": 59.5}),
    ("pinhole_barrel", {"model": "pinhole", "width": 160, "height": 120, "fx": 90.0, "fy": 91.0, "cx": 80.25,
                        "cy": 59.75, "k1": -0.2, "k2": 0.04}),
]


def bumpy_tube(around=96, along=120, length=100.0):
    """A tube along -z curving towards +x, its radius rippled (6 mm +- 1), as float32 vertices and triangles."""
    verts = []
    for j in range(along + 1):
        s = length * j / along
        cx, cz = 0.002 * s * s, -s  # the centerline bends towards +x
        for i in range(around):
            a = 2 * np.pi * i / around
            r = 6.0 + 0.7 * np.sin(3 * a) * np.cos(0.2 * s) + 0.3 * np.sin(7 * a + 0.5 * s)
            verts.append([cx + r * np.cos(a), r * np.sin(a), cz])
    tris = []
    for j in range(along):
        for i in range(around):
            v00, v01 = j * around + i, j * around + (i + 1) % around
            v10, v11 = v00 + around, v01 + around
            tris += [[v00, v10, v11], [v00, v11, v01]]
    # Vertices as the OBJ stores them (6 decimals), then as Mucosa's floats.
    verts = np.round(np.array(verts), 6).astype(np.float32).astype(np.float64)
    return verts, np.array(tris)


def write_obj(path, verts, tris):
    with open(path, "w") as f:
        for v in verts:
            f.write(f"v {v[0]:.6f} {v[1]:.6f} {v[2]:.6f}\n")
        for t in tris:
            f.write(f"f {t[0] + 1} {t[1] + 1} {t[2] + 1}\n")


def look_at(eye, target, up):
    """camera_to_world with OpenCV axes: z towards target, y down (up maps to -y)."""
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(-up, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, z, eye
    return m


def nearest_hits(origin, dirs, verts, tris):
    """Per ray (rows of dirs), the nearest triangle it meets and the distance (-1, inf where none)."""
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    e1, e2 = b - a, c - a
    s = origin - a
    best_tri = np.full(len(dirs), -1)
    best_t = np.full(len(dirs), np.inf)
    for k, d in enumerate(dirs):
        p = np.cross(d, e2)
        det = np.sum(e1 * p, axis=1)
        ok = np.abs(det) > 1e-14
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        u = np.sum(s * p, axis=1) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = np.sum(e2 * q, axis=1) * inv
        hit = ok & (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9) & (t > 0.5)
        if hit.any():
            t = np.where(hit, t, np.inf)
            best_tri[k] = int(np.argmin(t))
            best_t[k] = float(t[best_tri[k]])
    return best_tri, best_t


def main():
    tool, work = sys.argv[1], sys.argv[2]
    os.makedirs(work, exist_ok=True)
    verts, tris = bumpy_tube()
    obj = os.path.join(work, "tube.obj")
    write_obj(obj, verts, tris)
    c2w = look_at(np.array([0.5, -0.8, -3.0]), np.array([2.0, 0.5, -40.0]), np.array([0.0, 1.0, 0.0]))
    R, t = c2w[:3, :3], c2w[:3, 3]
    rvec, _ = cv2.Rodrigues(R.T)
    tvec = (-R.T @ t).reshape(3, 1)
    rng = np.random.default_rng(7)
    failures = []
    for name, lens in LENSES:
        path = os.path.join(work, name + ".json")
        with open(path, "w") as f:
            json.dump(lens, f)
        r = subprocess.run([tool, "--truth", path, obj], input=" ".join(f"{v:.17g}" for v in c2w.ravel()),
                           capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"FAIL: lens_points --truth {name}: {r.stderr.strip()}")
        lines = r.stdout.splitlines()
        header = lines[0].split()
        if int(header[1]) != len(tris):
            sys.exit(f"FAIL: {name}: Mucosa read {header[1]} triangles, the OBJ has {len(tris)}")
        rows = np.array([[float(x) for x in ln.split()] for ln in lines[1:]]).reshape(-1, 6)
        x, y, face = rows[:, 0].astype(int), rows[:, 1].astype(int), rows[:, 2].astype(int)
        b1, b2, depth = rows[:, 3], rows[:, 4], rows[:, 5]
        W, H = lens["width"], lens["height"]
        K = np.array([[lens["fx"], 0, lens["cx"]], [0, lens["fy"], lens["cy"]], [0, 0, 1]], dtype=np.float64)
        fisheye = lens["model"] == "fisheye"
        D = np.array([lens.get(k, 0.0) for k in ("k1", "k2", "k3", "k4")] if fisheye
                     else [lens["k1"], lens["k2"], 0.0, 0.0], dtype=np.float64)
        if len(x) < 0.5 * W * H:
            failures.append(f"{name}: only {len(x)} of {W * H} pixels see the wall")
        if face.min() < 0 or face.max() >= len(tris):
            failures.append(f"{name}: face ids outside 0..{len(tris) - 1}")
            continue
        # The mesh point each pixel names, projected by OpenCV.
        b0 = 1 - b1 - b2
        world = (b0[:, None] * verts[tris[face, 0]] + b1[:, None] * verts[tris[face, 1]]
                 + b2[:, None] * verts[tris[face, 2]])
        cam = (world - t) @ R
        if fisheye:
            proj, _ = cv2.fisheye.projectPoints(world.reshape(-1, 1, 3), rvec, tvec, K, D)
        else:
            proj, _ = cv2.projectPoints(world.reshape(-1, 1, 3), rvec, tvec, K, D)
        err = np.linalg.norm(proj.reshape(-1, 2) - np.stack([x, y], axis=1), axis=1)
        rms, worst = float(np.sqrt(np.mean(err ** 2))), float(np.max(err))
        dz = float(np.max(np.abs(cam[:, 2] - depth) / depth))
        print(f"{name}: {len(x)} pixels; the named mesh points through OpenCV land on their pixels: RMS {rms:.1e} px, "
              f"worst {worst:.1e} px; planar depth within {dz:.1e}")
        if rms > 0.1 or worst > 0.1:
            failures.append(f"{name}: mesh points projected by OpenCV RMS {rms} px, worst {worst} px")
        if dz > 1e-4:
            failures.append(f"{name}: planar depth off by {dz} relative")
        # First hits: OpenCV's ray of sampled pixels against every triangle.
        sample = rng.choice(W * H, 300, replace=False)
        sx, sy = (sample % W).astype(np.float64), (sample // W).astype(np.float64)
        if fisheye:
            # Only rays short of 90 degrees: OpenCV's fisheye undistorts to
            # x/z, which folds the rays beyond it forward (Mucosa gives them
            # no planar depth).
            th = 0.99 * np.pi / 2
            limit = th * (1 + D[0] * th ** 2 + D[1] * th ** 4 + D[2] * th ** 6 + D[3] * th ** 8)
            keep = np.hypot((sx - K[0, 2]) / K[0, 0], (sy - K[1, 2]) / K[1, 1]) < limit
            sample, sx, sy = sample[keep], sx[keep], sy[keep]
        px = np.stack([sx, sy], axis=1).reshape(-1, 1, 2)
        if fisheye:
            und = cv2.fisheye.undistortPoints(px, K, D)
        else:  # iterated to convergence: the default 5 iterations are 1e-3 px off at the barrel's edge
            und = cv2.undistortPointsIter(px, K, D, None, None,
                                          (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-15))
        und = und.reshape(-1, 2)
        rays = np.stack([und[:, 0], und[:, 1], np.ones(len(und))], axis=1)
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        tri, dist = nearest_hits(t, rays @ R.T, verts, tris)
        named = {(int(a), int(b)): (int(f), float(d)) for a, b, f, d in zip(x, y, face, depth)}
        disagree = 0
        for k in range(len(sample)):
            got = named.get((int(sx[k]), int(sy[k])))
            if got is None:
                disagree += tri[k] >= 0
            elif tri[k] < 0:
                disagree += 1
            elif tri[k] != got[0] and abs(dist[k] * rays[k, 2] - got[1]) > 1e-6 * got[1]:
                disagree += 1
        print(f"{name}: {len(sample)} sampled pixels, OpenCV's ray meets the named triangle first at "
              f"{len(sample) - disagree}")
        if disagree:
            failures.append(f"{name}: {disagree} of {len(sample)} sampled pixels see another triangle first")
    finish(failures)


if __name__ == "__main__":
    main()
