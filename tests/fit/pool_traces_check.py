#!/usr/bin/env python3
"""bench/fit/pool_traces.py on two made-up traces whose pooled statistics are
known: medians and p95s by bench_patient's rounding, losses counted across
a run of more than 10 lost frames only, a bad trace refused in one line."""
import os
import subprocess
import sys
import tempfile

script = sys.argv[1]
with tempfile.TemporaryDirectory() as tmp:
    a, b, bad = (os.path.join(tmp, n) for n in ("a.trace", "b.trace", "bad.trace"))
    # a: 100 frames, position 0.01 * i mm, orientation 0.05 * i deg but
    # frames 60..71 (12 in a row) at 11 deg: one loss.
    a_deg = [11.0 if 60 <= i < 72 else 0.05 * i for i in range(100)]
    with open(a, "w") as f:
        for i in range(100):
            f.write(f"pq {i} {0.01 * i:.3f} {a_deg[i]:.3f} 0.9 {1 if i % 2 else 0} 0 -1 -1\n")
    # b: 100 frames at 1 mm / 1 deg but 10 frames in a row at 20 deg (not a loss).
    b_deg = [20.0 if 40 <= i < 50 else 1.0 for i in range(100)]
    with open(b, "w") as f:
        for i in range(100):
            f.write(f"pq {i} 1.000 {b_deg[i]:.3f} 0.9 1 0 -1 -1\n")
    with open(bad, "w") as f:
        f.write("pq 0 0.1\n")
    out = subprocess.run([sys.executable, script, a, b], capture_output=True, text=True, check=True).stdout
    lines = out.strip().splitlines()
    assert len(lines) == 3, out
    # a alone: positions 0..0.99, median index round(0.5 * 99) = 50 -> 0.50
    # mm, p95 index round(94.05) = 94 -> 0.94 mm; orientations: 88 values
    # 0.05 * i below 5 deg and 12 at 11 deg, so the median (index 50) is
    # 0.05 * 50 = 2.50 and the p95 (index 94) one of the elevens; 50 converged.
    assert "position median 0.50 mm p95 0.94 mm" in lines[0], lines[0]
    assert "orientation median 2.50 deg p95 11.00 deg" in lines[0], lines[0]
    assert "50 converged, 1 losses" in lines[0], lines[0]
    assert "orientation median 1.00 deg p95 20.00 deg" in lines[1], lines[1]
    assert "0 losses" in lines[1], lines[1]
    # Pooled: the 200 values together, not the mean of the two runs' figures.
    deg = sorted(a_deg + b_deg)
    want = f"orientation median {deg[100]:.2f} deg p95 {deg[189]:.2f} deg"
    assert want in lines[2], (want, lines[2])
    assert "position median 1.00 mm p95 1.00 mm" in lines[2], lines[2]
    assert "pooled pq (2 traces): 200 frames" in lines[2], lines[2]
    assert "150 converged, 1 losses" in lines[2], lines[2]
    r = subprocess.run([sys.executable, script, a, bad], capture_output=True, text=True)
    assert r.returncode != 0, r
    assert r.stderr.count("\n") == 1 and r.stderr.startswith(f"error: trace in {bad}: line 1"), r.stderr
print("pool_traces: ok")
