"""Shared helpers for the study's end-to-end tests (server API, browser, load).

Makes a small stimulus set, a plan, and runs `mucosa study serve` on a free
loopback port. Every helper raises (never skips) when something is missing.
"""
import json
import os
import re
import signal
import subprocess
import time
import urllib.error
import urllib.request

from PIL import Image, ImageDraw, ImageFilter


def make_images(folder, patients=2, poses=3, size=(240, 180)):
    """Airway-like stimuli: a dark lumen in pink tissue, sharper for higher categories."""
    images = []
    for c in range(1, 6):
        for p in range(1, patients + 1):
            for q in range(1, poses + 1):
                im = Image.new("RGB", size, (150 + 10 * p, 70 + 8 * q, 70))
                d = ImageDraw.Draw(im)
                cx, cy = size[0] // 2 + 12 * (q - 2), size[1] // 2 + 8 * (p - 1)
                for r, col in ((70, (185, 95, 90)), (48, (120, 40, 45)), (26, (30, 8, 10))):
                    d.ellipse([cx - r, cy - r * 0.8, cx + r, cy + r * 0.8], fill=col)
                if c >= 4:  # specular glints
                    for k in range(14):
                        x = (37 * k * q + 11 * p) % size[0]
                        y = (53 * k + 7 * q) % size[1]
                        d.ellipse([x, y, x + 3 + k % 3, y + 2], fill=(255, 245, 240))
                im = im.filter(ImageFilter.GaussianBlur(radius=[4, 2.5, 1.2, 0.8, 0.3][c - 1]))
                d = ImageDraw.Draw(im)
                name = f"c{c}_p{p}_v{q}.png"
                im.save(os.path.join(folder, name), optimize=True)
                images.append({"id": f"C{c}_P{p}_V{q}", "file": name, "category": c,
                               "patient": p, "pose": q})
    path = os.path.join(folder, "images.json")
    with open(path, "w") as f:
        json.dump({"images": images}, f, indent=1)
    return path


def run(cli, *args, check=True):
    r = subprocess.run([cli, *args], capture_output=True, text=True, timeout=120)
    if check and r.returncode != 0:
        raise RuntimeError(f"mucosa {' '.join(args)} failed ({r.returncode}): {r.stderr}")
    return r


def make_plan(cli, folder, observers=4, seed=3, extra=()):
    manifest = make_images(folder)
    plan = os.path.join(folder, "study.json")
    run(cli, "study", "plan", "--manifest", manifest, "-o", plan, "--observers", str(observers),
        "--seed", str(seed), *extra)
    with open(plan) as f:
        return plan, json.load(f)


class Server:
    """`mucosa study serve` on a free loopback port; its observer links are
    written with --links-out to `links` (default: beside the database), and
    `tokens[i]` is slot i's secret."""

    def __init__(self, cli, plan, db, extra=(), port=0, links=None):
        self.links_file = links or db + ".links.txt"
        self.proc = subprocess.Popen([cli, "study", "serve", plan, "--db", db, "--port", str(port),
                                      "--links-out", self.links_file, *extra],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        line = self.proc.stdout.readline()
        m = re.search(r"http://([0-9.]+):(\d+)/", line)
        if not m:
            self.proc.kill()
            raise RuntimeError(f"server did not start: {line!r} {self.proc.stderr.read()}")
        self.base = f"http://127.0.0.1:{m.group(2)}"
        with open(self.links_file) as f:  # written before the line above
            self.links = f.read().split()
        self.tokens = [re.search(r"\?t=([0-9a-f]+)$", u).group(1) for u in self.links]

    def kill(self):  # SIGKILL: no chance to flush or clean up
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(timeout=30)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        return self.proc.returncode


def request(base, method, path, body=None, raw=None, timeout=30, token=None):
    """Returns (status, parsed JSON or text). Never raises on HTTP errors.
    `token`: the observer link's secret, sent as Authorization: Bearer."""
    data = raw if raw is not None else (json.dumps(body).encode() if body is not None else None)
    headers = {"Content-Type": "application/json", "Connection": "close"}
    if token is not None:
        headers["Authorization"] = "Bearer " + token
    req = urllib.request.Request(base + path, data=data, method=method, headers=headers)
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            status, payload, ctype = r.status, r.read(), r.headers.get("Content-Type", "")
    except urllib.error.HTTPError as e:
        status, payload, ctype = e.code, e.read(), e.headers.get("Content-Type", "")
    if "json" in ctype:
        return status, json.loads(payload)
    return status, payload


def expected_rows(plan, slot, answers):
    """The rows the database must hold for an observer in `slot` who gave `answers` (trial order)."""
    images = plan["images"]
    rows = []
    for i, (trial, ans) in enumerate(zip(plan["observers"][slot]["trials"], answers)):
        if trial["kind"] == "likert":
            im = images[trial["image"]]
            rows.append((i, "likert", str(ans), im["id"], im["category"], int(ans), None))
        elif trial["kind"] == "twoafc":
            l, r = images[trial["left"]], images[trial["right"]]
            chosen = l["category"] if ans == "left" else r["category"]
            rows.append((i, "twoafc", ans, l["id"] + "|" + r["id"], None, None, chosen))
        else:
            l, r = images[trial["left"]], images[trial["right"]]
            rows.append((i, "calibration", "seen", l["id"] + "|" + r["id"], None, None, None))
    return rows


def db_rows(db, observer):
    import sqlite3
    con = sqlite3.connect(db)
    try:
        out = []
        for (trial, kind, answer, image_id, category, score, left_id, right_id, chosen) in con.execute(
                "SELECT trial, kind, answer, image_id, category, score, left_id, right_id, chosen_category "
                "FROM answers WHERE observer = ? ORDER BY trial", (observer,)):
            ident = image_id if kind == "likert" else f"{left_id}|{right_id}"
            out.append((trial, kind, answer, ident, category, score, chosen))
        return out
    finally:
        con.close()
