"""Bounded load test: N simulated observers at once on loopback, every one
completing a short study; afterwards the database must hold every answer
exactly once. Bounded in count and time (a deadline, not a timing assertion).

Usage: load_test.py MUCOSA_CLI WORK_DIR [OBSERVERS]
"""
import os
import random
import shutil
import sys
import threading
import time
import urllib.error

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import study_fixture as fx  # noqa: E402

cli, work = sys.argv[1], sys.argv[2]
n_obs = int(sys.argv[3]) if len(sys.argv) > 3 else 200
DEADLINE_S = 540
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
plan_path, plan = fx.make_plan(cli, work, observers=n_obs, seed=11,
                               extra=("--likert", "10", "--twoafc", "2"))
db = os.path.join(work, "answers.sqlite")
# Every simulated observer comes from 127.0.0.1, like a class behind one NAT:
# the per-address connection cap is raised as the docs say to.
srv = fx.Server(cli, plan_path, db, extra=("--client-connections", "512"))
start = threading.Barrier(n_obs)
given = {}
errors = []
retries = [0]
lock = threading.Lock()
latencies = []


def call(method, path, body, token):
    # A simulated observer retries like the page does: a refused or dropped
    # connection is not an answer; the same answer is sent again.
    for attempt in range(60):
        try:
            t0 = time.perf_counter()
            s, payload = fx.request(srv.base, method, path, body, timeout=60, token=token)
            with lock:
                latencies.append(time.perf_counter() - t0)
            if s in (200, 409, 400, 404):
                return s, payload
        except (urllib.error.URLError, ConnectionError, TimeoutError, OSError):
            pass
        with lock:
            retries[0] += 1
        time.sleep(min(2.0, 0.05 * 2 ** attempt))
    raise RuntimeError(f"{path}: no answer after 60 attempts")


def observer(i):
    rng = random.Random(i)
    oid = f"L{i:03d}"
    token = srv.tokens[i]  # observer i's link
    group = "naive" if i % 3 else "expert"
    answers = []
    try:
        start.wait(timeout=120)
        s, st = call("POST", "/api/session", {"observer": oid, "group": group}, token)
        if s != 200:
            raise RuntimeError(f"session {s} {st}")
        while not st["done"]:
            kind = st["screen"]["kind"]
            a = {"calibration": "seen", "likert": rng.randint(1, 5), "twoafc": rng.choice(["left", "right"])}[kind]
            s, nxt = call("POST", "/api/answer", {"observer": oid, "trial": st["trial"], "answer": a}, token)
            if s == 409:  # our earlier send was stored but its reply was lost: ask where we are
                s, nxt = call("GET", f"/api/state?observer={oid}", None, token)
            if s != 200:
                raise RuntimeError(f"answer {st['trial']}: {s} {nxt}")
            if nxt["trial"] != st["trial"] + 1:
                raise RuntimeError(f"asked screen {nxt['trial']} after {st['trial']}")
            answers.append(a)
            st = nxt
        with lock:
            given[oid] = (plan_slot_of(oid), answers)
    except Exception as e:  # noqa: BLE001 - collected and reported
        with lock:
            errors.append(f"{oid}: {e}")


def plan_slot_of(oid):
    import sqlite3
    con = sqlite3.connect(db)
    try:
        return con.execute("SELECT slot FROM observers WHERE observer=?", (oid,)).fetchone()[0]
    finally:
        con.close()


t0 = time.time()
threads = [threading.Thread(target=observer, args=(i,), daemon=True) for i in range(n_obs)]
for t in threads:
    t.start()
for t in threads:
    t.join(timeout=max(1, DEADLINE_S - (time.time() - t0)))
elapsed = time.time() - t0
alive = sum(t.is_alive() for t in threads)
peak_kb = 0
with open(f"/proc/{srv.proc.pid}/status") as f:  # the server's peak resident memory
    for line in f:
        if line.startswith("VmHWM:"):
            peak_kb = int(line.split()[1])
srv.stop()

failures = list(errors)
if alive:
    failures.append(f"{alive} observer(s) still running after {DEADLINE_S} s")
stored = 0
for oid, (slot, answers) in sorted(given.items()):
    rows = fx.db_rows(db, oid)
    stored += len(rows)
    if rows != fx.expected_rows(plan, slot, answers):
        failures.append(f"{oid}: database differs from the answers given")
expected_total = n_obs * len(plan["observers"][0]["trials"])
if stored != expected_total or len(given) != n_obs:
    failures.append(f"stored {stored} answers of {len(given)} observers, expected {expected_total} of {n_obs}")
# The database analyses, and its CSV export analyses to the same numbers.
import json  # noqa: E402
r1 = fx.run(cli, "study", "analyze", db, "-o", os.path.join(work, "from_db"), check=False)
r2 = fx.run(cli, "study", "analyze", os.path.join(work, "from_db", "ratings.csv"), "--twoafc",
            os.path.join(work, "from_db", "pairs.csv"), "-o", os.path.join(work, "from_csv"), check=False)
if r1.returncode or r2.returncode:
    failures.append(f"analyze failed: {r1.stderr} {r2.stderr}")
else:
    def load(folder):
        with open(os.path.join(work, folder, "stats.json")) as f:
            j = json.load(f)
        j["meta"].pop("source")
        return j
    a, b = load("from_db"), load("from_csv")
    if a != b:
        failures.append("stats from the database and from its CSV export differ")
    n_likert = sum(a["all"]["categories"][c]["n_ratings"] for c in a["all"]["categories"])
    n_afc = sum(v["n"] for v in a["all"]["twoafc"].values())
    if n_likert != n_obs * 10 or n_afc != n_obs * 6 or a["all"]["n_observers"] != n_obs:
        failures.append(f"analysis of the load database counts {n_likert} ratings, {n_afc} choices")

latencies.sort()
print(f"load: {n_obs} concurrent observers, {stored} answers stored of {expected_total} given, "
      f"{retries[0]} retried requests, {elapsed:.1f} s wall, {stored / elapsed:.0f} answers/s, "
      f"request latency median {1000 * latencies[len(latencies) // 2]:.1f} ms, "
      f"p99 {1000 * latencies[int(len(latencies) * 0.99)]:.1f} ms, server peak memory {peak_kb / 1024:.1f} MiB")
for f in failures[:20]:
    print("FAIL", f)
sys.exit(1 if failures else 0)
