"""Cross-check of `mucosa study analyze` against SciPy on constructed data:
heavy ties, zero differences, tiny groups, exact-test cases, degenerate cases,
2AFC edge counts. Statistics to 1e-9, p-values to 1e-6 relative. Each check
names the SciPy call it compares with.

Usage: scipy_crosscheck.py MUCOSA_CLI WORK_DIR   (run with Debian's /usr/bin/python3)
"""
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import warnings

import numpy as np
import scipy
from scipy import stats

warnings.simplefilter("ignore")  # scipy warns on tiny samples; we compare anyway
cli, work = sys.argv[1], sys.argv[2]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
STAT_TOL, P_TOL = 1e-9, 1e-6
n_checks = 0
failures = []
worst = {"stat": 0.0, "p": 0.0}


def close_stat(ours, ref, what):
    global n_checks
    n_checks += 1
    err = abs(ours - ref) / max(1.0, abs(ref))  # absolute for |x| <= 1, relative above
    worst["stat"] = max(worst["stat"], err)
    if not err <= STAT_TOL:
        failures.append(f"{what}: ours {ours!r} scipy {ref!r}")


def close_p(ours, ref, what):
    global n_checks
    n_checks += 1
    err = abs(ours - ref) / abs(ref) if ref != 0 else abs(ours)
    worst["p"] = max(worst["p"], err)
    if not err <= P_TOL:
        failures.append(f"{what}: p ours {ours!r} scipy {ref!r}")


def undefined(ours_value, ref_value, what):
    global n_checks
    n_checks += 1
    if not (ours_value is None and (ref_value is None or math.isnan(ref_value))):
        failures.append(f"{what}: ours {ours_value!r}, scipy {ref_value!r} (both must be undefined)")


def analyze(name, ratings, choices=None):
    folder = os.path.join(work, name)
    os.makedirs(folder)
    path = os.path.join(folder, "ratings.csv")
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["observer", "group", "category", "image_id", "score", "patient"])
        for i, (o, g, c, s) in enumerate(ratings):
            w.writerow([o, g, c, f"img{i}", s, 1])
    args = [cli, "study", "analyze", path, "-o", os.path.join(folder, "report")]
    if choices:
        cpath = os.path.join(folder, "pairs.csv")
        with open(cpath, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["observer", "group", "left_category", "right_category", "chosen_category"])
            w.writerows(choices)
        args += ["--twoafc", cpath]
    r = subprocess.run(args, capture_output=True, text=True, timeout=120)
    if r.returncode != 0:
        raise RuntimeError(f"{name}: analyze failed: {r.stderr}")
    with open(os.path.join(folder, "report", "stats.json")) as f:
        return json.load(f)


def check_dataset(name, ratings, choices=None):
    st = analyze(name, ratings, choices)
    groups = ["all"] + [g for g in ("naive", "expert") if any(r[1] == g for r in ratings)]
    for g in groups:
        rows = [r for r in ratings if g == "all" or r[1] == g]
        cats = sorted({r[2] for r in ratings})
        obs = list(dict.fromkeys(r[0] for r in rows))
        means = {}  # observer -> category -> mean
        for o in obs:
            for c in cats:
                v = [r[3] for r in rows if r[0] == o and r[2] == c]
                if v:
                    means.setdefault(o, {})[c] = np.mean(np.array(v, dtype=float))
        G = st[g]
        for c in cats:
            x = np.array([r[3] for r in rows if r[2] == c], dtype=float)
            if len(x) == 0:
                continue
            e = G["categories"][str(c)]
            close_stat(e["mean"], x.mean(), f"{name}/{g}/c{c} mean (np.mean)")
            if len(x) > 1:
                close_stat(e["sd"], x.std(ddof=1), f"{name}/{g}/c{c} sd (np.std(ddof=1))")
            else:
                undefined(e["sd"], None, f"{name}/{g}/c{c} sd of one rating")
        # scipy.stats.friedmanchisquare(*columns), complete blocks only
        complete = [o for o in obs if len(means.get(o, {})) == len(cats)]
        f = G["friedman"]
        if len(cats) >= 3 and complete:
            cols = [[means[o][c] for o in complete] for c in cats]
            ref = stats.friedmanchisquare(*cols)
            if math.isnan(ref.statistic) or math.isinf(ref.statistic):
                undefined(f["chi2"], float("nan"), f"{name}/{g} friedman (all tied)")
            else:
                close_stat(f["chi2"], ref.statistic, f"{name}/{g} friedman chi2 (scipy.stats.friedmanchisquare)")
                close_p(f["p"], ref.pvalue, f"{name}/{g} friedman p (scipy.stats.friedmanchisquare)")
                close_stat(f["kendalls_w"], ref.statistic / (len(complete) * (len(cats) - 1)), f"{name}/{g} W")
                assert f["n_blocks"] == len(complete)
        for c in cats:
            if c == 5:
                continue
            pairs = [(means[o][c], means[o][5]) for o in obs if c in means.get(o, {}) and 5 in means.get(o, {})]
            w = G["wilcoxon"][str(c)]
            x = np.array([p[0] for p in pairs])
            y = np.array([p[1] for p in pairs])
            d = x - y
            if len(pairs) == 0 or np.all(d == 0):
                undefined(w["T"], None, f"{name}/{g}/c{c} wilcoxon with no non-zero difference")
                continue
            # scipy.stats.wilcoxon(x, y, zero_method='wilcox', correction=False, method='approx')
            ref = stats.wilcoxon(x, y, zero_method="wilcox", correction=False, method="approx")
            close_stat(w["T"], ref.statistic, f"{name}/{g}/c{c} wilcoxon T (scipy.stats.wilcoxon approx)")
            close_stat(w["z"], ref.zstatistic, f"{name}/{g}/c{c} wilcoxon z")
            close_p(w["p"], ref.pvalue, f"{name}/{g}/c{c} wilcoxon p (scipy.stats.wilcoxon approx)")
            nz = d[d != 0]
            exact_ok = len(nz) == len(d) and len(np.unique(np.abs(nz))) == len(nz)
            if exact_ok:
                # scipy.stats.wilcoxon(x, y, method='exact')
                ref_e = stats.wilcoxon(x, y, method="exact")
                close_p(w["p_exact"], ref_e.pvalue, f"{name}/{g}/c{c} wilcoxon exact p (method='exact')")
            elif "p_exact" in w:
                failures.append(f"{name}/{g}/c{c}: p_exact given although there are zeros or ties")
            # ROC: AUC = 1 - U_pos / (n1 n0), U from scipy.stats.mannwhitneyu(pos, neg)
            pos = np.array([r[3] for r in rows if r[2] == c], dtype=float)
            neg = np.array([r[3] for r in rows if r[2] == 5], dtype=float)
            if len(pos) and len(neg):
                u = stats.mannwhitneyu(pos, neg, alternative="two-sided", method="asymptotic").statistic
                close_stat(G["roc"][str(c)]["auc"], 1 - u / (len(pos) * len(neg)), f"{name}/{g}/c{c} ROC AUC vs U")
                # per observer: the same area from that observer's ratings only
                per = []
                for o, ours in zip(G["observers"], G["roc"][str(c)]["observer_auc"]):
                    po = [r[3] for r in rows if r[0] == o and r[2] == c]
                    ne = [r[3] for r in rows if r[0] == o and r[2] == 5]
                    if not po or not ne:
                        undefined(ours, None, f"{name}/{g}/c{c} observer {o} AUC without both categories")
                        continue
                    u_o = stats.mannwhitneyu(po, ne, alternative="two-sided", method="asymptotic").statistic
                    per.append(1 - u_o / (len(po) * len(ne)))
                    close_stat(ours, per[-1], f"{name}/{g}/c{c} observer {o} AUC (mannwhitneyu U)")
                if per:
                    close_stat(G["roc"][str(c)]["observer_auc_mean"], np.mean(per), f"{name}/{g}/c{c} observer AUC mean")
                pts = [[float(np.mean(neg <= t)), float(np.mean(pos <= t))] for t in range(6)]
                for (a, b), (pa, pb) in zip(G["roc"][str(c)]["points"], pts):
                    close_stat(a, pa, f"{name}/{g}/c{c} ROC fpr")
                    close_stat(b, pb, f"{name}/{g}/c{c} ROC tpr")
        if choices:
            for key, e in G["twoafc"].items():
                a, b = map(int, key.split("_vs_"))
                sel = [ch for ch in choices if (g == "all" or ch[1] == g) and {ch[2], ch[3]} == {a, b}]
                k = sum(ch[4] == b for ch in sel)
                # scipy.stats.binomtest(k, n, 0.5); .proportion_ci(0.95, method='wilson')
                ref = stats.binomtest(k, len(sel), 0.5)
                ci = ref.proportion_ci(confidence_level=0.95, method="wilson")
                assert e["n"] == len(sel) and e["k"] == k
                close_p(e["p"], ref.pvalue, f"{name}/{g} 2AFC {key} p (scipy.stats.binomtest)")
                close_stat(e["ci95_wilson"][0], ci.low, f"{name}/{g} 2AFC {key} Wilson low")
                close_stat(e["ci95_wilson"][1], ci.high, f"{name}/{g} 2AFC {key} Wilson high")
    if "naive_vs_expert" in st:
        for c, e in st["naive_vs_expert"].items():
            c = int(c)
            for unit in ("observer_means", "ratings"):
                if unit == "ratings":
                    a = [r[3] for r in ratings if r[1] == "naive" and r[2] == c]
                    b = [r[3] for r in ratings if r[1] == "expert" and r[2] == c]
                else:
                    def om(gr):
                        os_ = dict.fromkeys(r[0] for r in ratings if r[1] == gr and r[2] == c)
                        return [np.mean([r[3] for r in ratings if r[0] == o and r[2] == c]) for o in os_]
                    a, b = om("naive"), om("expert")
                # scipy.stats.mannwhitneyu(naive, expert, alternative='two-sided', method='asymptotic', use_continuity=True)
                ref = stats.mannwhitneyu(a, b, alternative="two-sided", method="asymptotic", use_continuity=True)
                if math.isnan(ref.pvalue):
                    undefined(e[unit]["p"], ref.pvalue, f"{name} naive/expert c{c} {unit} (all tied)")
                    continue
                close_stat(e[unit]["U"], ref.statistic, f"{name} naive/expert c{c} {unit} U (scipy.stats.mannwhitneyu)")
                close_p(e[unit]["p"], ref.pvalue, f"{name} naive/expert c{c} {unit} p (scipy.stats.mannwhitneyu)")
    print(f"checked {name}")


rng = np.random.default_rng(20061)

# 1. Heavy ties: 6 observers whose scores are almost all 3 or 4.
r1 = [(f"T{o}", "naive" if o < 4 else "expert", c, int(rng.choice([3, 4], p=[0.7, 0.3])))
      for o in range(6) for c in range(1, 6) for _ in range(4)]
check_dataset("heavy_ties", r1)

# 2. Zero differences: observers whose category means equal their category-5 mean.
r2 = []
for o in range(9):
    base = [2, 3, 3, 4, 4, 5][o % 6]
    for c in range(1, 6):
        for k in range(2):
            s = base if (c >= 3 and o % 3 == 0) else min(5, max(1, base + (c - 5) // 2 + k))
            r2.append((f"Z{o}", "naive" if o % 2 else "expert", c, s))
check_dataset("zero_differences", r2)

# 3. Tiny groups: 2 experts, 3 naive, one rating per category; plus 2AFC edge counts.
r3 = [(o, g, c, int(rng.integers(1, 6))) for o, g in (("a", "naive"), ("b", "naive"), ("c", "naive"),
                                                       ("d", "expert"), ("e", "expert")) for c in range(1, 6)]
ch3 = [("a", "naive", 3, 4, 4)] + [("d", "expert", 5, 4, 5)] * 3 + [("b", "naive", 3, 5, 3), ("e", "expert", 3, 5, 5)]
check_dataset("tiny_groups", r3, ch3)

# 4. Exact case: distinct non-tied mean differences (varying counts per observer).
r4 = []
for o in range(12):
    n = 3 + o
    for c in range(1, 6):
        for k in range(n):
            r4.append((f"X{o}", "naive" if o < 7 else "expert", c, 1 + (k * (c + o) + o * o + c) % 5))
check_dataset("exact_case", r4)

# 5. Paper-sized random study with 2AFC.
r5, ch5 = [], []
for o in range(23):
    g = "naive" if o < 16 else "expert"
    bias = rng.normal(0, 0.4)
    for c in range(1, 6):
        for _ in range(40):
            r5.append((f"P{o:02d}", g, c, int(np.clip(np.rint(1 + 0.8 * c + bias + rng.normal(0, 1)), 1, 5))))
    for a, b, pb in ((3, 4, 0.68), (3, 5, 0.73), (4, 5, 0.48)):
        for _ in range(10):
            left, right = (a, b) if rng.random() < 0.5 else (b, a)
            ch5.append((f"P{o:02d}", g, left, right, b if rng.random() < pb else a))
check_dataset("paper_sized", r5, ch5)

# 6. All ties everywhere: Friedman and Wilcoxon undefined (scipy gives nan).
r6 = [(f"Q{o}", "naive" if o < 2 else "expert", c, 3) for o in range(4) for c in range(1, 6)]
check_dataset("all_tied", r6)

print(f"scipy {scipy.__version__}: {n_checks} checks, worst statistic error {worst['stat']:.2e} "
      f"(tolerance {STAT_TOL}), worst p-value relative error {worst['p']:.2e} (tolerance {P_TOL})")
for f in failures[:30]:
    print("FAIL", f)
sys.exit(1 if failures else 0)
