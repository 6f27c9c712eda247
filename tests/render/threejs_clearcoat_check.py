"""The clearcoat mode against a real glTF renderer: three.js (npm three,
MeshPhysicalMaterial through GLTFLoader) in headless Debian Chromium (WebGL on
SwiftShader) renders the phantom with its KHR_materials_clearcoat material
from the camera of a Mucosa `clearcoat` frame, lit by a point light at the
camera; the two frames must agree within the tolerances below (MAX_MAE,
MIN_SSIM, MAX_GLINT_MAE), as three.js ships and again without its
screen-space geometric roughness (docs/rendering.md, "The clearcoat mode:
glTF's clear coat", lists what is matched).

Usage: threejs_clearcoat_check.py MUCOSA_CLI WORK_DIR [PICTURE.png]
Fails (never skips) when chromium or tools/node/node_modules/three is missing.
Loopback only: the page, three's modules and the .glb are served on
127.0.0.1 at a free port.
"""
import base64
import http.server
import io
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import threading

import numpy as np
from PIL import Image
from scipy.ndimage import binary_erosion, gaussian_filter

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.dirname(os.path.dirname(HERE))
THREE = os.path.join(SOURCE, "tools", "node", "node_modules", "three")
CHROMIUM = "/usr/bin/chromium"

# The comparison's tolerances, over the pixels both render. Measured on the
# phantom with its irregular cartilage rings: MAE 0.60/255, bias -0.06, SSIM
# 0.997, glints 20.2 (as three ships; 0.61, -0.01, 0.998 and 10.0 without its
# geometric roughness). Looser tolerances (<= 3/255, >= 0.95) would not catch
# what these catch (docs/rendering.md): the coat's Fresnel on the geometry's
# normal (MAE 1.03, SSIM 0.968), the coat without its pi (glints 49.6), the
# base's diffuse without (1 - F) (MAE 0.89, bias +0.86), three's mirrored coat
# normal (MAE 2.0, SSIM 0.91).
MAX_MAE = 0.75  # mean absolute error, 0..255, all channels
MAX_BIAS = 0.5  # |mean signed difference|, 0..255
MIN_SSIM = 0.99  # Wang et al. 2004 on the luma
MAX_GLINT_MAE = 30.0  # MAE over the pixels where either frame has a glint (min channel > 200)
MIN_GLINTS = 30  # the coat must show: at least this many glint pixels in Mucosa's frame

W, H = 640, 480
FOV_X_DEG = 90.0  # Mucosa's fov_deg is across the larger side
NEAR_MM, FAR_MM = 0.5, 300.0
EYE_MM = [-1.6, -92.0, -3.2]  # in the trachea, looking at the carina
LOOK_AT_MM = [-0.5, -120.0, -3.0]
UP = [0.0, 0.0, 1.0]
EV = -1.0  # fixed exposure 2^EV (no auto-exposure)
MATERIAL = {  # registry values (mucosa params): the clearcoat mode's and the .glb's
    "base_color": [0.75, 0.27, 0.12],
    "mucus_opacity": 0.0,  # so the albedo is base_color x COLOR_0 in both
    "bump_scale": 1.0,
    "map_tiling": 4.0,
    "ambient": 0.03,
    "sheen": 0.6,
    "sheen_shininess": 8.0,
    "mucus_ior": 1.34,
    "clearcoat": 0.83,
    "clearcoat_roughness": 0.254,
}
LIGHT = {"intensity": 400.0, "source_radius_mm": 0.01, "spread": 0.0}


def fail(msg):
    sys.exit(f"FAIL: {msg}")


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        fail(f"{' '.join(cmd)} exited {r.returncode}: {r.stderr.strip()}")
    return r.stdout


def read_glb(path):
    data = open(path, "rb").read()
    magic, version, total = struct.unpack_from("<III", data, 0)
    if magic != 0x46546C67 or version != 2:
        fail(f"{path} is not a glTF 2.0 binary")
    off, doc, binary = 12, None, b""
    while off < total:
        length, kind = struct.unpack_from("<II", data, off)
        chunk = data[off + 8 : off + 8 + length]
        if kind == 0x4E4F534A:
            doc = json.loads(chunk)
        elif kind == 0x004E4942:
            binary = bytes(chunk)
        off += 8 + length
    return doc, binary


def write_glb(path, doc, binary):
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    with open(path, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, total))
        f.write(struct.pack("<II", len(js), 0x4E4F534A) + js)
        f.write(struct.pack("<II", len(binary), 0x004E4942) + binary)


def ggx_roughness_from_phong(n):
    """The glTF base's roughness the clearcoat mode uses (shading::glsl::packMaterial)."""
    return math.sqrt(math.sqrt(2.0 / (4.0 * n + 2.0)))


def flat_normal_png():
    buf = io.BytesIO()
    Image.new("RGB", (1, 1), (128, 128, 255)).save(buf, "PNG")
    return buf.getvalue()


def clearcoat_glb(phantom_glb, map_png, out):
    """The phantom's .glb (metres, UVs, tangents, COLOR_0) with the clearcoat
    mode's material in glTF terms: the base (baseColorFactor = base_color,
    metallic 0, roughness from sheen_shininess, KHR_materials_ior = mucus_ior,
    KHR_materials_specular = sheen) under KHR_materials_clearcoat (factor,
    roughness, the reflectance map as clearcoatNormalTexture, scale =
    bump_scale, tiled by map_tiling through KHR_texture_transform)."""
    doc, binary = read_glb(phantom_glb)
    doc["images"] = []
    for name, png in (("reflectance map", open(map_png, "rb").read()), ("flat normal", flat_normal_png())):
        binary += b"\0" * (-len(binary) % 4)
        doc["bufferViews"].append({"buffer": 0, "byteOffset": len(binary), "byteLength": len(png)})
        binary += png
        doc["images"].append({"bufferView": len(doc["bufferViews"]) - 1, "mimeType": "image/png", "name": name})
    doc["buffers"][0]["byteLength"] = len(binary) + (-len(binary) % 4)
    doc["samplers"] = [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}]
    doc["textures"] = [{"source": 0, "sampler": 0}, {"source": 1, "sampler": 0}]
    t = MATERIAL["map_tiling"]
    # Mucosa samples the map at t (u, v), OpenGL's v up; glTF's v' = 1 - v and
    # its image origin is the top-left: the same texel at t v' + (1 - t).
    transform = {"scale": [t, t], "offset": [0.0, (1.0 - t) - math.floor(1.0 - t)]}
    m = MATERIAL
    doc["materials"] = [{
        "name": "mucosa clearcoat",
        "pbrMetallicRoughness": {
            "baseColorFactor": m["base_color"] + [1.0],
            "metallicFactor": 0.0,
            "roughnessFactor": ggx_roughness_from_phong(m["sheen_shininess"]),
        },
        # A flat base normal texture (scale 0: exactly the geometry's normal).
        # three.js r187 reads a mesh's TANGENT only when the material has a
        # base normal map (WebGLPrograms: vertexTangents = tangent &&
        # (normalMap || anisotropy)); with a clearcoat normal map alone it
        # builds the coat's frame from screen-space derivatives of glTF's
        # (downward) v, mirroring the map's y, and GLTFLoader does not
        # correct it because the mesh has tangents. With this texture three
        # uses the .glb's tangents, as the specification asks.
        "normalTexture": {"index": 1, "scale": 0.0},
        "extensions": {
            "KHR_materials_clearcoat": {
                "clearcoatFactor": m["clearcoat"],
                "clearcoatRoughnessFactor": m["clearcoat_roughness"],
                "clearcoatNormalTexture": {"index": 0, "scale": m["bump_scale"],
                                           "extensions": {"KHR_texture_transform": transform}},
            },
            "KHR_materials_ior": {"ior": m["mucus_ior"]},
            "KHR_materials_specular": {"specularFactor": m["sheen"]},
        },
    }]
    doc["extensionsUsed"] = ["KHR_materials_clearcoat", "KHR_materials_ior", "KHR_materials_specular",
                             "KHR_texture_transform"]
    write_glb(out, doc, binary)


def mucosa_frame(cli, work, glb, map_png):
    scene = {
        "mesh": os.path.basename(glb),
        "closed": True,
        "diffuse": "none",
        "reflectance_map": os.path.basename(map_png),
        "filter": "trilinear",
        "mode": "clearcoat",
        "specular_aa": True,
        "material": MATERIAL,
        "light": LIGHT,
        "camera": {"fov_deg": FOV_X_DEG, "near_mm": NEAR_MM, "far_mm": FAR_MM,
                   "auto_exposure": 0, "exposure_ev": EV, "vignetting": 0, "mask": 0, "softness_px": 0,
                   "full_well": 0, "read_noise": 0, "tone_curve": 2, "saturation": 1, "flare": 0,
                   "pose": {"position": EYE_MM, "look_at": LOOK_AT_MM, "up": UP}},
        "resolution": [W, H],
    }
    path = os.path.join(work, "clearcoat_scene.json")
    json.dump(scene, open(path, "w"), indent=1)
    out = os.path.join(work, "mucosa.png")
    run([cli, "render", path, "-o", out])
    return out


def three_frame(work, glb, geometry_roughness=True):
    """Renders the .glb in headless Chromium; returns the PNG path and three's report."""
    exposure = 2.0 ** EV
    # three's physical point light: irradiance I / max(d^2, 0.01) (decay 2;
    # the clamp in scene units^2), radiance albedo / pi x irradiance x cos.
    # Mucosa's radiance is albedo x E cos with E = I_L / d^2 (d in mm, spread
    # 0, source radius 0.01 mm): so the scene is drawn in millimetres (the
    # .glb's metres x 1000, clear of the clamp) and three's I = pi I_L. Its
    # ambient light gives albedo / pi x intensity: pi x Mucosa's ambient
    # irradiance. Mucosa's exposure goes into both (three applies none
    # without tone mapping).
    ambient_e = MATERIAL["ambient"] * LIGHT["intensity"] / (10.0 * 10.0)  # shading: ambientIrradiance
    fov_y = 2.0 * math.degrees(math.atan(math.tan(math.radians(FOV_X_DEG / 2.0)) * H / W))
    params = {
        "width": W, "height": H, "glb": "/asset/" + os.path.basename(glb), "sceneScale": 1000.0,
        "fovYDeg": fov_y, "near": NEAR_MM, "far": FAR_MM, "eye": EYE_MM, "lookAt": LOOK_AT_MM, "up": UP,
        "pointIntensity": math.pi * LIGHT["intensity"] * exposure,
        "ambientIntensity": math.pi * ambient_e * exposure,
        "noGeometryRoughness": not geometry_roughness,
    }
    page = open(os.path.join(HERE, "threejs_clearcoat.html"), "rb").read()
    done = threading.Event()
    result = {}

    class Handler(http.server.BaseHTTPRequestHandler):
        def log_message(self, *a):
            pass

        def send(self, body, ctype):
            self.send_response(200)
            self.send_header("Content-Type", ctype)
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def do_GET(self):
            p = self.path.split("?")[0]
            if p in ("/", "/index.html"):
                return self.send(page, "text/html")
            if p == "/params.json":
                return self.send(json.dumps(params).encode(), "application/json")
            roots = {"/three/": THREE, "/asset/": work}
            for prefix, root in roots.items():
                if p.startswith(prefix):
                    f = os.path.realpath(os.path.join(root, p[len(prefix):]))
                    if f.startswith(os.path.realpath(root)) and os.path.isfile(f):
                        ctype = "text/javascript" if f.endswith(".js") else "application/octet-stream"
                        return self.send(open(f, "rb").read(), ctype)
            self.send_response(404)
            self.end_headers()

        def do_POST(self):
            body = self.rfile.read(int(self.headers["Content-Length"]))
            result[self.path] = body
            self.send(b"ok", "text/plain")
            if self.path in ("/result", "/error"):
                done.set()

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    url = f"http://127.0.0.1:{server.server_address[1]}/"
    profile = tempfile.mkdtemp(prefix="mucosa-chromium-")
    browser = subprocess.Popen(
        [CHROMIUM, "--headless=new", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
         "--ignore-gpu-blocklist", "--no-sandbox", "--no-first-run", "--disable-extensions",
         f"--user-data-dir={profile}", f"--window-size={W},{H}", url],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        if not done.wait(300):
            fail("three.js did not render within 300 s")
    finally:
        browser.kill()
        _, err = browser.communicate()
        server.shutdown()
        shutil.rmtree(profile, ignore_errors=True)
    if "/error" in result:
        fail(f"three.js page: {result['/error'].decode()}")
    info = json.loads(result.get("/info", b"{}"))
    data = result["/result"].decode()
    prefix = "data:image/png;base64,"
    if not data.startswith(prefix):
        fail("the canvas did not come back as a PNG")
    out = os.path.join(work, "three.png" if geometry_roughness else "three_no_geometry_roughness.png")
    open(out, "wb").write(base64.b64decode(data[len(prefix):]))
    return out, info


def luma(img):
    return img[..., 0] * 0.2126 + img[..., 1] * 0.7152 + img[..., 2] * 0.0722


def ssim_map(a, b, L=255.0, sigma=1.5):
    """Wang, Bovik, Sheikh, Simoncelli 2004: Gaussian window sigma 1.5, K1 0.01, K2 0.03."""
    c1, c2 = (0.01 * L) ** 2, (0.03 * L) ** 2
    g = lambda x: gaussian_filter(x, sigma, truncate=3.5)  # the 11 x 11 window
    mu_a, mu_b = g(a), g(b)
    va = g(a * a) - mu_a ** 2
    vb = g(b * b) - mu_b ** 2
    cov = g(a * b) - mu_a * mu_b
    return ((2 * mu_a * mu_b + c1) * (2 * cov + c2)) / ((mu_a ** 2 + mu_b ** 2 + c1) * (va + vb + c2))


def main():
    if len(sys.argv) < 3:
        fail("usage: threejs_clearcoat_check.py MUCOSA_CLI WORK_DIR [PICTURE.png]")
    cli, work = sys.argv[1], sys.argv[2]
    picture = sys.argv[3] if len(sys.argv) > 3 else None
    if not os.path.exists(CHROMIUM):
        fail(f"{CHROMIUM} is missing (scripts/install-deps: apt-get install chromium)")
    if not os.path.isfile(os.path.join(THREE, "build", "three.module.js")):
        fail(f"three is missing from {THREE} (run scripts/install-deps)")
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)

    phantom = os.path.join(work, "airway.glb")
    run([cli, "phantom", "-o", phantom, "--resolution", "1"])
    map_png = os.path.join(work, "map.png")
    run([cli, "map", "-o", map_png, "--preset", "bronchial", "--size", "512", "--tileable"])
    glb = os.path.join(work, "airway_clearcoat.glb")
    clearcoat_glb(phantom, map_png, glb)

    ours = mucosa_frame(cli, work, glb, map_png)
    a = np.asarray(Image.open(ours).convert("RGB"), dtype=np.float64)
    failures = []
    for geometry_roughness in (True, False):
        theirs, info = three_frame(work, glb, geometry_roughness)
        print("three.js:", json.dumps(info))
        if info.get("material") != "MeshPhysicalMaterial" or not info.get("clearcoatNormalMap"):
            fail(f"GLTFLoader did not make a clear-coated MeshPhysicalMaterial: {info}")
        b = np.asarray(Image.open(theirs).convert("RGB"), dtype=np.float64)
        if a.shape != b.shape:
            fail(f"sizes differ: {a.shape} vs {b.shape}")
        both = (a.max(axis=2) > 0) & (b.max(axis=2) > 0)
        coverage = both.sum() / both.size
        diff = np.abs(a - b)
        mae = diff[both].mean()
        bias = (a - b)[both].mean()
        inner = binary_erosion(both, iterations=5)  # SSIM windows inside the rendered area
        ssim = ssim_map(luma(a), luma(b))[inner].mean()
        ga, gb = a.min(axis=2) > 200, b.min(axis=2) > 200
        glint_mae = diff[ga | gb].mean() if (ga | gb).any() else 0.0
        name = "three.js" if geometry_roughness else "three.js without its geometric roughness"
        print(f"{name}: pixels both render {100 * coverage:.1f} %, mean absolute error {mae:.3f}/255 "
              f"(<= {MAX_MAE}), bias {bias:+.3f} (|.| <= {MAX_BIAS}), SSIM {ssim:.4f} (>= {MIN_SSIM}), 99th percentile of |diff| "
              f"{np.percentile(diff[both], 99):.0f}/255; glint pixels (min channel > 200) Mucosa {int(ga.sum())}, "
              f"three.js {int(gb.sum())}, MAE over them {glint_mae:.1f}/255 (<= {MAX_GLINT_MAE})")
        if coverage < 0.5 or mae > MAX_MAE or abs(bias) > MAX_BIAS or ssim < MIN_SSIM or glint_mae > MAX_GLINT_MAE or ga.sum() < MIN_GLINTS:
            failures.append(f"{name}: coverage {coverage:.3f}, MAE {mae:.3f}, bias {bias:+.3f}, SSIM {ssim:.4f}, "
                            f"glint MAE {glint_mae:.1f}, {int(ga.sum())} glint pixels")
        if picture and geometry_roughness:
            d8 = np.clip(diff.max(axis=2) * 8, 0, 255)
            gap = np.full((H, 8, 3), 255.0)
            side = np.concatenate([a, gap, b, gap, np.repeat(d8[..., None], 3, axis=2)], axis=1)
            Image.fromarray(side.astype(np.uint8)).save(picture)
            print(f"wrote {picture} (Mucosa clearcoat | three.js | |difference| x 8)")
    if failures:
        fail("Mucosa's clearcoat frame and three.js's disagree: " + "; ".join(failures) + f" (frames in {work})")
    print("PASS")


if __name__ == "__main__":
    main()
