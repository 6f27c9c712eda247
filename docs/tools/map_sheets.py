#!/usr/bin/python3
"""README pictures of reflectance maps: presets and the paper's Fig. 3 point.

Runs `mucosa map` for each preset and for a frequency sweep, and lays out
height field / reflectance map / a lit preview per column. The preview is a
flat wet patch under a point light 0.25 map-widths above its centre, viewed
from the light (the endoscope geometry), Blinn-Phong exponent 60: the way the
map breaks up the specular highlight, which is the method's whole point.
Usage: docs/tools/map_sheets.py path/to/mucosa docs/images
(needs Debian's python3-numpy and python3-pil: /usr/bin/python3)
"""
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

MUCOSA, OUT = sys.argv[1], Path(sys.argv[2])
TILE = 220


def make(args, tmp, name):
    png = Path(tmp) / f"{name}.png"
    height = Path(tmp) / f"{name}_h.png"
    subprocess.run([MUCOSA, "-q", "map", "-o", str(png), "--height-out", str(height), *args], check=True)
    return np.asarray(Image.open(png)).astype(np.float64), np.asarray(Image.open(height)).astype(np.float64)


def lit(rgb):
    n = rgb / 255.0 * 2.0 - 1.0
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    h, w, _ = n.shape
    # Texture space: +u right, +v up (first row is v = 1).
    u = (np.arange(w) + 0.5) / w
    v = 1.0 - (np.arange(h) + 0.5) / h
    uu, vv = np.meshgrid(u, v)
    p = np.stack([uu, vv, np.zeros_like(uu)], axis=2)
    light = np.array([0.5, 0.5, 0.25])
    L = light - p
    L /= np.linalg.norm(L, axis=2, keepdims=True)
    H = L  # viewer at the light: half vector = L
    ndoth = np.clip((n * H).sum(axis=2), 0, 1)
    ndotl = np.clip((n * L).sum(axis=2), 0, 1)
    base = np.array([0.72, 0.33, 0.30])
    img = base[None, None, :] * (0.15 + 0.85 * ndotl[..., None]) + 0.9 * ndoth[..., None] ** 60
    return Image.fromarray((np.clip(img, 0, 1) ** (1 / 2.2) * 255).astype(np.uint8))


def column(rgb, height):
    hmin, hmax = height.min(), height.max()
    h8 = ((height - hmin) / max(1e-9, hmax - hmin) * 255).astype(np.uint8)
    tiles = [Image.fromarray(h8).convert("RGB"), Image.fromarray(rgb.astype(np.uint8)), lit(rgb)]
    return [t.resize((TILE, TILE), Image.LANCZOS) for t in tiles]


def sheet(columns, titles, rows, path):
    pad, top, left = 8, 26, 110
    W = left + len(columns) * (TILE + pad)
    Hh = top + 3 * (TILE + pad)
    img = Image.new("RGB", (W, Hh), "white")
    d = ImageDraw.Draw(img)
    for c, (col, title) in enumerate(zip(columns, titles)):
        x = left + c * (TILE + pad)
        d.text((x + 4, 6), title, fill="black")
        for r, tile in enumerate(col):
            img.paste(tile, (x, top + r * (TILE + pad)))
    for r, label in enumerate(rows):
        d.text((6, top + r * (TILE + pad) + TILE // 2), label, fill="black")
    img.save(path, quality=88, optimize=True)


with tempfile.TemporaryDirectory() as tmp:
    names = ["serosa", "bronchial", "rough", "fine"]
    cols = [column(*make(["--preset", n, "--size", "512"], tmp, n)) for n in names]
    sheet(cols, names, ["height H", "reflectance map", "lit preview"], OUT / "presets.jpg")
    freqs = [4, 16, 64]
    cols = [column(*make(["--preset", "bronchial", "--size", "512", "--frequency", str(f),
                          "--octaves", "3", "--strength", str(0.008 * 16 / f)], tmp, f"f{f}")) for f in freqs]
    sheet(cols, [f"frequency {f}" for f in freqs], ["height H", "reflectance map", "lit preview"],
          OUT / "frequency.jpg")
print("wrote", OUT / "presets.jpg", "and", OUT / "frequency.jpg")
