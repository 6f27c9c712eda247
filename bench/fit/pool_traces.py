#!/usr/bin/env python3
"""Pools bench_patient traces (MUCOSA_TRACE files) of several sequences.

    pool_traces.py TRACE...

Prints, per trace and over all of them together, the position and
orientation error's median and p95, frames converged and losses (error
> 5 mm or > 10 degrees for more than 10 frames in a row), the statistics
bench_patient prints per run. Percentiles are bench_patient's: the value at
index round(q * (n - 1)) of the sorted errors (the trace's errors are
rounded to 3 decimals). Standard library only.
"""
import signal
import sys


def percentile(values, q):
    s = sorted(values)
    return s[min(len(s) - 1, int(q * (len(s) - 1) + 0.5))] if s else float("nan")


def losses(rows):
    n, run = 0, 0
    for mm, deg in rows:
        run = run + 1 if (mm > 5 or deg > 10) else 0
        if run == 11:
            n += 1
    return n


def summary(name, rows, converged):
    mm = [r[0] for r in rows]
    deg = [r[1] for r in rows]
    return (f"{name}: {len(rows)} frames | position median {percentile(mm, 0.5):.2f} mm p95 "
            f"{percentile(mm, 0.95):.2f} mm | orientation median {percentile(deg, 0.5):.2f} deg p95 "
            f"{percentile(deg, 0.95):.2f} deg | {converged} converged")


def main(paths):
    if not paths:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    pooled, pooled_converged, pooled_losses = {}, {}, {}
    for path in paths:
        per = {}
        conv = {}
        try:
            with open(path) as f:
                for number, line in enumerate(f, 1):
                    fields = line.split()
                    if len(fields) < 6:
                        raise ValueError(f"line {number} has {len(fields)} fields, not at least 6")
                    label = fields[0]
                    per.setdefault(label, []).append((float(fields[2]), float(fields[3])))
                    conv[label] = conv.get(label, 0) + int(fields[5])
        except (OSError, ValueError) as e:
            print(f"error: trace in {path}: {e}", file=sys.stderr)
            return 1
        for label, rows in per.items():
            lost = losses(rows)
            print(summary(f"{path} {label}", rows, conv[label]) + f", {lost} losses")
            pooled.setdefault(label, []).extend(rows)
            pooled_converged[label] = pooled_converged.get(label, 0) + conv[label]
            pooled_losses[label] = pooled_losses.get(label, 0) + lost
    for label, rows in pooled.items():
        print(summary(f"pooled {label} ({len(paths)} traces)", rows, pooled_converged[label]) +
              f", {pooled_losses[label]} losses")
    return 0


if __name__ == "__main__":
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # piped into head: stop quietly
    sys.exit(main(sys.argv[1:]))
