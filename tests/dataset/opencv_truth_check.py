#!/usr/bin/python3
"""Ground truth of `mucosa render --outputs` checked with OpenCV.

Usage: opencv_truth_check.py MUCOSA_CLI WORK_DIR

Renders frames of the airway phantom (written as OBJ, so the triangles
can be read back independently of Mucosa) with depth, normals, mask and face
outputs, then, for every pixel that sees the wall:
  - back-projects it with the manifest's intrinsics and camera_to_world and
    projects the 3-D point again with cv2.projectPoints (OpenCV's pinhole,
    its own axes and pixel convention): it must land on the pixel;
  - checks the point lies on the triangle the face output names (distance to
    its plane), and that cv2.projectPoints of that triangle's three vertices
    encloses the pixel;
  - checks the normal is unit length and faces the camera;
  - checks the flow to the previous frame is cv2.projectPoints of the point
    into the previous camera minus the pixel.
Debian's python3-opencv and python3-numpy; a missing module fails the test.
"""
import json
import os
import sys

from truth_check_common import cv2, face_planes, np, read_exr, read_obj, reprojection_rms, run


def main():
    cli, work = sys.argv[1], sys.argv[2]
    os.makedirs(work, exist_ok=True)
    run(cli, "phantom", "-o", "airway.obj", "--generations", "1", "--resolution", "1", cwd=work)
    # 30 frames along the path (a few mm apart, so the flow has a previous
    # frame that sees the same wall); the first three are checked.
    run(cli, "render", "airway.obj", "-o", "f.png", "--frames", "30", "--size", "128x96", "--overwrite",
        "--outputs", "rgb,depth,normals,mask,face,flow", cwd=work)
    verts, tris = read_obj(os.path.join(work, "airway.obj"))
    manifest = json.load(open(os.path.join(work, "f.frames.json")))
    failures = []
    previous = None  # the previous frame's (rvec, tvec, K)
    for i, fr in enumerate(manifest["frames"][:3]):
        k = fr["intrinsics"]
        K = np.array([[k["fx"], 0, k["cx"]], [0, k["fy"], k["cy"]], [0, 0, 1]], dtype=np.float64)
        c2w = np.array(fr["camera_to_world"], dtype=np.float64)
        R, t = c2w[:3, :3], c2w[:3, 3]
        if abs(np.linalg.det(R) - 1) > 1e-6:
            failures.append(f"frame {i}: camera_to_world is not a rotation (det {np.linalg.det(R)})")
        stem = os.path.join(work, f"f_{i:04d}")
        depth = read_exr(stem + ".depth.exr")
        face = read_exr(stem + ".face.exr").astype(np.int64)
        normals = read_exr(stem + ".normals.exr")[:, :, ::-1]  # OpenCV reads B, G, R
        v, u = np.nonzero(depth > 0)
        if len(u) < 0.5 * depth.size:
            failures.append(f"frame {i}: only {len(u)} pixels see the wall")
        z = depth[v, u].astype(np.float64)
        cam = np.stack([(u - K[0, 2]) / K[0, 0] * z, (v - K[1, 2]) / K[1, 1] * z, z], axis=1)
        world = cam @ R.T + t
        rvec, _ = cv2.Rodrigues(R.T)
        tvec = -R.T @ t
        proj, _ = cv2.projectPoints(world, rvec, tvec, K, None)
        reprojection_rms(proj, np.stack([u, v], axis=1), "cv2.projectPoints", i, failures)
        # The face output: the point is on that triangle of the OBJ.
        planes = face_planes(face[v, u], verts, tris)
        if planes is None:
            failures.append(f"frame {i}: face ids outside 0..{len(tris) - 1}")
            continue
        a, b, c, n = planes
        dist = np.abs(np.sum((world - a) * n, axis=1))
        worst = float(np.max(dist / z))
        print(f"frame {i}: distance to the named triangle's plane, worst {worst:.2e} x depth")
        if worst > 1e-4:
            failures.append(f"frame {i}: a point is {worst} x depth off its face's plane")
        # cv2.projectPoints of the triangle's corners encloses the pixel (0.1 px slack).
        corners = np.stack([a, b, c], axis=1).reshape(-1, 3)
        pc, _ = cv2.projectPoints(corners, rvec, tvec, K, None)
        pc = pc.reshape(-1, 3, 2)
        px = np.stack([u, v], axis=1).astype(np.float64)

        def edge(p, q):
            e = q - p
            w = px - p
            cross = e[:, 0] * w[:, 1] - e[:, 1] * w[:, 0]
            return cross / np.maximum(np.linalg.norm(e, axis=1), 1e-12)  # signed distance in pixels

        e0, e1, e2 = edge(pc[:, 0], pc[:, 1]), edge(pc[:, 1], pc[:, 2]), edge(pc[:, 2], pc[:, 0])
        inside = ((e0 >= -0.1) & (e1 >= -0.1) & (e2 >= -0.1)) | ((e0 <= 0.1) & (e1 <= 0.1) & (e2 <= 0.1))
        print(f"frame {i}: pixels inside their face's projected triangle: {inside.mean() * 100:.2f} %")
        if not inside.all():
            failures.append(f"frame {i}: {np.count_nonzero(~inside)} pixels outside their face's projection")
        nv = normals[v, u].astype(np.float64)
        unit = float(np.max(np.abs(np.linalg.norm(nv, axis=1) - 1)))
        facing = float(np.mean(np.sum(nv * cam, axis=1) < 0))
        print(f"frame {i}: normals: |n| - 1 worst {unit:.1e}, facing the camera {facing * 100:.1f} %")
        if unit > 1e-5 or facing < 1:
            failures.append(f"frame {i}: normals not unit or not facing the camera")
        flow = read_exr(stem + ".flow.exr")[:, :, ::-1]  # du, dv, visible
        if previous is None:
            if np.any(flow != 0):
                failures.append(f"frame {i}: the first frame has flow")
        else:
            pp, _ = cv2.projectPoints(world, *previous)
            expected = pp.reshape(-1, 2) - np.stack([u, v], axis=1)
            got = flow[v, u, :2].astype(np.float64)
            seen = flow[v, u, 2] > 0
            ferr = float(np.max(np.abs(got - expected)))
            print(f"frame {i}: flow against cv2.projectPoints into the previous camera: worst {ferr:.1e} px, "
                  f"{seen.mean() * 100:.1f} % visible before")
            if ferr > 1e-3 or seen.mean() < 0.5:
                failures.append(f"frame {i}: flow off by {ferr} px or too little visible ({seen.mean()})")
        previous = (rvec, tvec, K, None)
    if failures:
        print("\n".join("FAIL: " + f for f in failures))
        sys.exit(1)
    print("ok")


if __name__ == "__main__":
    main()
