#!/usr/bin/env bash
# Regenerates the seed corpora under fuzz/corpus/ (small valid and near-valid
# inputs for every harness). Needs a release build: fuzz/make_seeds.sh build/release/mucosa
# The seeds are committed; run this only to refresh them.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
mucosa="$(realpath "${1:-$here/../build/release/mucosa}")"
c="$here/corpus"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
mkdir -p "$c"/{png,exr,scene,frames,camera,pose,sidecar,brdf,ratings_csv,twoafc_csv,plan,manifest,mesh}

# Maps: 8- and 16-bit PNGs, a 16-bit height PNG, an EXR height field, their sidecar.
"$mucosa" -q map --size 8 --octaves 2 -o "$tmp/m8.png" --height-out "$tmp/h.exr"
"$mucosa" -q map --size 8 --octaves 2 --bits 16 -o "$tmp/m16.png" --height-out "$tmp/h16.png"
cp "$tmp/m8.png" "$c/png/seed_map8.png"; cp "$tmp/m16.png" "$c/png/seed_map16.png"
cp "$tmp/h16.png" "$c/png/seed_height16.png"; cp "$tmp/h.exr" "$c/exr/seed_height.exr"
cp "$tmp/m8.json" "$c/sidecar/seed_map8.json"; cp "$tmp/m16.json" "$c/sidecar/seed_map16.json"
# Gray, palette and RGBA-with-tRNS PNGs (the decoder's other colour types).
/usr/bin/python3 - "$c/png" <<'PY'
import sys
from PIL import Image
d = sys.argv[1]
Image.new("L", (5, 3), 77).save(f"{d}/seed_gray.png")
Image.new("P", (4, 4), 2).save(f"{d}/seed_palette.png", transparency=2)
Image.new("LA", (3, 3), (10, 200)).save(f"{d}/seed_gray_alpha.png")
Image.new("1", (9, 2), 1).save(f"{d}/seed_1bit.png")
PY

# Scenes.
printf '%s' '{"mesh": "tube", "mode": "noise", "width": 64, "height": 48}' > "$c/scene/seed_tube.json"
printf '%s' '{"mesh": "phantom", "mode": "procedural", "noise_space": "object", "light": {"offset_mm": [1, 0, 0]},
 "reflectance_map": {"preset": "bronchial", "size": 64}, "camera": {"path": "centerline", "frames": 3}}' > "$c/scene/seed_phantom.json"
printf '%s' '{"mesh": "m.ply", "reflectance_map": "maps/m.png", "mode": "brdf-noise", "fit": "fit/brdf.json"}' > "$c/scene/seed_files.json"

# Frames, BRDF.
printf '%s' '{"units": "mm", "frames": [{"image": "f.png", "intrinsics": {"width": 32, "height": 32, "fx": 20, "fy": 20, "cx": 16, "cy": 16},
 "camera_to_world": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}' > "$c/frames/seed_one.json"
printf '%s' '{"frames": []}' > "$c/frames/seed_empty.json"
# mucosa register's camera and pose files.
printf '%s' '{"intrinsics": {"width": 320, "height": 320, "fx": 180, "fy": 180, "cx": 159.5, "cy": 159.5, "k1": -0.2, "k2": 0.05}, "gamma": 2.2, "light": {"offset": [2.5, 0, 0]}, "units": "mm"}' > "$c/camera/seed_camera.json"
printf '%s' '{"intrinsics": {"width": 8, "height": 8, "fx": 4, "fy": 4, "cx": 3.5, "cy": 3.5}}' > "$c/camera/seed_minimal.json"
printf '%s' '{"position": [0, 0, -10], "look_at": [0, 0, 40], "up": [0, 1, 0]}' > "$c/pose/seed_lookat.json"
printf '%s' '{"camera_to_world": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}' > "$c/pose/seed_matrix.json"
printf '%s' '{"c": [0.1, 0.01, -0.001, 0.00001], "d": [0.9, 0.02, 0.0, 0.0], "zmin": 2, "zmax": 45, "samples": 1000, "rms": 0.01}' > "$c/brdf/seed_brdf.json"

# Study: ratings and 2AFC CSV, a manifest and the plan made from it.
head -c 2000 "$here/../tests/data/study/ratings_A_main.csv" | sed '$d' > "$c/ratings_csv/seed_ratings.csv"
printf 'observer,group,left_category,right_category,chosen_category\nN01,naive,3,5,5\nE01,expert,4,5,4\n' > "$c/twoafc_csv/seed_twoafc.csv"
imgs=""
for cat in 1 2 3 4 5; do for pose in 1 2; do
  : > "$tmp/c${cat}_v${pose}.png"
  imgs="$imgs{\"id\":\"c${cat}_v${pose}\",\"file\":\"c${cat}_v${pose}.png\",\"category\":$cat,\"patient\":1,\"pose\":$pose},"
done; done
printf '{"images":[%s]}' "${imgs%,}" > "$tmp/images.json"
cp "$tmp/images.json" "$c/manifest/seed_images.json"
"$mucosa" -q study plan --manifest "$tmp/images.json" -o "$tmp/plan.json" --observers 2 --seed 1
cp "$tmp/plan.json" "$c/plan/seed_plan.json"

# Meshes: a tetrahedron in every format the project writes, plus ASCII/binary STL.
/usr/bin/python3 - "$tmp" <<'PY'
import struct, sys
d = sys.argv[1]
V = [(0,0,0),(10,0,0),(0,10,0),(0,0,10)]
F = [(0,2,1),(0,1,3),(0,3,2),(1,2,3)]
open(f"{d}/t.obj","w").write("".join(f"v {x} {y} {z}\n" for x,y,z in V) + "vt 0 0\nvt 1 0\nvt 0 1\n" +
    "".join(f"f {a+1}/1 {b+1}/2 {c+1}/3\n" for a,b,c in F))
ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
open(f"{d}/t_ascii.ply","w").write(ply + "".join(f"{x} {y} {z}\n" for x,y,z in V) + "".join(f"3 {a} {b} {c}\n" for a,b,c in F))
hdr = ply.replace("ascii", "binary_little_endian").encode()
body = b"".join(struct.pack("<3f", *v) for v in V) + b"".join(struct.pack("<B3i", 3, *f) for f in F)
open(f"{d}/t_bin.ply","wb").write(hdr + body)
def normal(a,b,c):
    u=[b[i]-a[i] for i in range(3)]; v=[c[i]-a[i] for i in range(3)]
    return (u[1]*v[2]-u[2]*v[1], u[2]*v[0]-u[0]*v[2], u[0]*v[1]-u[1]*v[0])
open(f"{d}/t_ascii.stl","w").write("solid t\n" + "".join(
    "facet normal %g %g %g\nouter loop\n" % normal(V[a],V[b],V[c]) + "".join("vertex %g %g %g\n" % V[i] for i in (a,b,c)) +
    "endloop\nendfacet\n" for a,b,c in F) + "endsolid t\n")
stl = b"\0"*80 + struct.pack("<I", len(F)) + b"".join(struct.pack("<12fH", *normal(V[a],V[b],V[c]), *V[a], *V[b], *V[c], 0) for a,b,c in F)
open(f"{d}/t_bin.stl","wb").write(stl)
PY
"$mucosa" -q mesh "$tmp/t.obj" -o "$tmp/t.glb" --unit mm
"$mucosa" -q mesh "$tmp/t.obj" -o "$tmp/t.gltf" --unit mm
for f in t.obj t_ascii.ply t_bin.ply t_ascii.stl t_bin.stl t.glb t.gltf; do cp "$tmp/$f" "$c/mesh/seed_$f"; done
[ -f "$tmp/t.bin" ] && cp "$tmp/t.bin" "$c/mesh/seed_t.bin" || true
echo "seeds written to $c"
