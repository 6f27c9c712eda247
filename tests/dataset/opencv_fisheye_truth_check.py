#!/usr/bin/python3
"""Ground truth of `mucosa render --lens` (a fisheye) checked with OpenCV.

Usage: opencv_fisheye_truth_check.py MUCOSA_CLI WORK_DIR

Renders frames of the airway phantom (written as OBJ, so its triangles are
read back independently of Mucosa) through a Kannala-Brandt fisheye with
depth, face and flow outputs, then, for every pixel that sees the wall:
  - back-projects it with OpenCV's own fisheye model (cv2.fisheye.undistortPoints
    with the manifest's lens: fx, fy, cx, cy, k1..k4) to the ray, scales it to
    the planar depth, and projects the 3-D point again with
    cv2.fisheye.projectPoints: it must land on the pixel;
  - checks the point lies on the triangle the face output names;
  - checks the flow to the previous frame is cv2.fisheye.projectPoints of the
    point into the previous camera minus the pixel, where it is visible.
Debian's python3-opencv and python3-numpy; a missing module fails the test.
"""
import json
import os
import sys

from truth_check_common import cv2, face_planes, finish, np, read_exr, read_obj, reprojection_rms, run


def main():
    cli, work = sys.argv[1], sys.argv[2]
    os.makedirs(work, exist_ok=True)
    lens = {"model": "fisheye", "width": 128, "height": 96, "fx": 52.0, "fy": 52.5, "cx": 63.2, "cy": 47.9,
            "k1": -0.03, "k2": 0.004, "k3": -0.001, "k4": 0.0001}
    with open(os.path.join(work, "fisheye.json"), "w") as f:
        json.dump(lens, f)
    run(cli, "phantom", "-o", "airway.obj", "--generations", "1", "--resolution", "1", cwd=work)
    run(cli, "render", "airway.obj", "-o", "f.png", "--frames", "30", "--size", "128x96", "--overwrite",
        "--lens", "fisheye.json", "--outputs", "rgb,depth,face,flow", cwd=work)
    verts, tris = read_obj(os.path.join(work, "airway.obj"))
    manifest = json.load(open(os.path.join(work, "f.frames.json")))
    L = manifest["lens"]
    K = np.array([[L["fx"], 0, L["cx"]], [0, L["fy"], L["cy"]], [0, 0, 1]], dtype=np.float64)
    D = np.array([L["k1"], L["k2"], L["k3"], L["k4"]], dtype=np.float64)
    failures = []
    previous = None
    for i, fr in enumerate(manifest["frames"][:3]):
        c2w = np.array(fr["camera_to_world"], dtype=np.float64)
        R, t = c2w[:3, :3], c2w[:3, 3]
        stem = os.path.join(work, f"f_{i:04d}")
        depth = read_exr(stem + ".depth.exr")
        face = read_exr(stem + ".face.exr").astype(np.int64)
        v, u = np.nonzero(depth > 0)
        if len(u) < 0.5 * depth.size:
            failures.append(f"frame {i}: only {len(u)} pixels see the wall")
        z = depth[v, u].astype(np.float64)
        px = np.stack([u, v], axis=1).astype(np.float64)
        # OpenCV's fisheye: pixel -> normalised (x/z, y/z) -> the point at planar depth z.
        und = cv2.fisheye.undistortPoints(px.reshape(-1, 1, 2), K, D).reshape(-1, 2)
        cam = np.stack([und[:, 0] * z, und[:, 1] * z, z], axis=1)
        world = cam @ R.T + t
        rvec, _ = cv2.Rodrigues(R.T)
        tvec = (-R.T @ t).reshape(3, 1)
        proj, _ = cv2.fisheye.projectPoints(world.reshape(-1, 1, 3), rvec, tvec, K, D)
        reprojection_rms(proj, px, "cv2.fisheye back-projection and projectPoints", i, failures)
        planes = face_planes(face[v, u], verts, tris)
        if planes is None:
            failures.append(f"frame {i}: face ids outside 0..{len(tris) - 1}")
            continue
        a, _, _, n = planes
        dist = np.abs(np.sum((world - a) * n, axis=1)) / z
        share = float(np.mean(dist <= 1e-4))
        print(f"frame {i}: on the named triangle's plane (1e-4 x depth): {100 * share:.3f} % of pixels, "
              f"worst {float(np.max(dist)):.2e}")
        if share < 0.999:
            failures.append(f"frame {i}: only {100 * share} % of points lie on their face's plane")
        if previous is not None:
            flow = read_exr(stem + ".flow.exr")[:, :, ::-1]  # OpenCV reads B, G, R
            visible = flow[v, u, 2] > 0
            pr, pt = previous
            pp, _ = cv2.fisheye.projectPoints(world[visible].reshape(-1, 1, 3), pr, pt, K, D)
            expect = pp.reshape(-1, 2) - px[visible]
            got = flow[v, u, :2][visible]
            ferr = float(np.max(np.abs(expect - got))) if len(got) else 0.0
            print(f"frame {i}: flow of {int(visible.sum())} visible pixels vs cv2.fisheye.projectPoints: "
                  f"worst {ferr:.2e} px")
            if visible.sum() < 0.3 * len(u) or ferr > 1e-2:
                failures.append(f"frame {i}: flow worst {ferr} px over {int(visible.sum())} pixels")
        previous = (rvec, tvec)
    finish(failures)


if __name__ == "__main__":
    main()
