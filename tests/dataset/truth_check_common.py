"""Shared by the OpenCV cross-checks of the ground truth: running the
command, reading the phantom's OBJ (independently of Mucosa) and EXRs."""
import os
import subprocess
import sys

os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"  # before cv2 is imported
import cv2  # noqa: E402
import numpy as np  # noqa: E402


def run(cli, *args, cwd):
    r = subprocess.run([cli, *args], cwd=cwd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"FAIL: mucosa {' '.join(args)}: {r.stderr.strip()}")


def read_obj(path):
    verts, tris = [], []
    with open(path) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                verts.append([float(x) for x in p[1:4]])
            elif p[0] == "f":
                idx = [int(x.split("/")[0]) - 1 for x in p[1:]]
                for k in range(1, len(idx) - 1):  # a fan, as OBJ readers triangulate
                    tris.append([idx[0], idx[k], idx[k + 1]])
    return np.array(verts), np.array(tris)


def read_exr(path):
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img is None:
        sys.exit(f"FAIL: OpenCV cannot read {path}")
    return img


def reprojection_rms(proj, px, label, i, failures):
    """RMS distance (pixels) between projected points and their pixels, printed and checked (0.1 px)."""
    err = np.linalg.norm(proj.reshape(-1, 2) - px, axis=1)
    rms = float(np.sqrt(np.mean(err ** 2)))
    print(f"frame {i}: {len(px)} pixels; back-projected and {label}: RMS {rms:.2e} px")
    if rms > 0.1:
        failures.append(f"frame {i}: {label} RMS {rms} px")


def face_planes(f, verts, tris):
    """Each named triangle's corners a, b, c and unit normal n (None when an id is outside the mesh)."""
    if f.min() < 0 or f.max() >= len(tris):
        return None
    a, b, c = verts[tris[f, 0]], verts[tris[f, 1]], verts[tris[f, 2]]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return a, b, c, n


def finish(failures):
    """Every failure on its own line and a non-zero exit, or PASS."""
    if failures:
        print("FAIL:\n  " + "\n  ".join(failures))
        sys.exit(1)
    print("PASS")
