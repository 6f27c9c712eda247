"""`mucosa study serve` over HTTP: observer links (tokens), resume,
idempotence, refusals, SIGKILL.

Usage: server_api_test.py MUCOSA_CLI WORK_DIR
"""
import json
import os
import random
import shutil
import sqlite3
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import study_fixture as fx  # noqa: E402

cli, work = sys.argv[1], sys.argv[2]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
plan_path, plan = fx.make_plan(cli, work, observers=3, extra=("--likert", "8", "--series", "4", "--twoafc", "2"))
db = os.path.join(work, "answers.sqlite")
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def answer_for(trial, rng):
    return {"calibration": "seen", "likert": rng.randint(1, 5), "twoafc": rng.choice(["left", "right"])}[trial["kind"]]


rng = random.Random(5)
srv = fx.Server(cli, plan_path, db)
tokens = list(srv.tokens)


def req(base, method, path, body=None, raw=None, token=None):
    """A request with slot 0's link (observer N01) unless another token is given ("" = none)."""
    token = tokens[0] if token is None else token
    return fx.request(base, method, path, body, raw=raw, token=token or None)


try:
    B = srv.base
    # --- observer links: one per slot, secret, in a 0600 file
    check(len(tokens) == 3 and len(set(tokens)) == 3 and all(len(t) == 32 for t in tokens)
          and all(int(t, 16) >= 0 for t in tokens), f"3 distinct 128-bit hex tokens: {tokens}")
    check(all(u.startswith(B + "/?t=") for u in srv.links), f"links are {B}/?t=TOKEN")
    check(os.stat(srv.links_file).st_mode & 0o777 == 0o600, "the links file is mode 0600")
    check(not [f for f in os.listdir(work) if ".tmp-" in f], "no temporary links file left behind")
    # --- without a valid token every data route is 401, with one body that names nothing
    wrong = "%032x" % random.Random(1).getrandbits(128)
    unauth_bodies = set()
    for tok, who in (("", "no token"), (wrong, "a wrong token"), (tokens[0][:-1], "a short token"),
                     (tokens[0].upper(), "an upper-cased token"), (tokens[0] + "0", "a long token")):
        for method, path, body in (("POST", "/api/session", {"observer": "N01", "group": "naive"}),
                                   ("POST", "/api/answer", {"observer": "N01", "trial": 0, "answer": "seen"}),
                                   ("GET", "/api/state", None), ("GET", "/api/state?observer=N01", None),
                                   ("GET", "/image/0", None), ("GET", "/image/0?t=" + tok, None)):
            s, r = req(B, method, path, body, token=tok)
            check(s == 401, f"{who}: {method} {path[:24]} -> 401 (got {s})")
            unauth_bodies.add(json.dumps(r) if isinstance(r, dict) else repr(r))
    check(len(unauth_bodies) == 1, f"every 401 says the same: {unauth_bodies}")
    s, page = req(B, "GET", "/", token="")
    check(s == 200 and b"screen-invalid" in page, "the page itself is served without a token (it says the link is invalid)")
    s, st = req(B, "GET", "/api/state")
    check(s == 200 and st == {"registered": False}, "a valid unused link: not registered yet")
    # --- sessions
    s, st = req(B, "POST", "/api/session", {"observer": "N01", "group": "naive"})
    check(s == 200 and st["trial"] == 0 and st["screen"]["kind"] == "calibration", "new observer starts at calibration")
    check("category" not in json.dumps(st) and "C1_" not in json.dumps(st), "screens never reveal categories or ids")
    s, _ = req(B, "POST", "/api/session", {"observer": "N01", "group": "expert"})
    check(s == 409, "same id, other group -> 409")
    s, _ = req(B, "POST", "/api/session", {"observer": "N99", "group": "naive"})
    check(s == 401, "slot 0's link is bound to N01: another id with it -> 401")
    s, _ = req(B, "POST", "/api/session", {"observer": "N01", "group": "naive"}, token=tokens[1])
    check(s == 401, "another slot's link cannot take the id N01 -> 401")
    for method, path, body in (("POST", "/api/answer", {"observer": "N01", "trial": 0, "answer": "seen"}),
                               ("GET", "/api/state?observer=N01", None)):
        s, _ = req(B, method, path, body, token=tokens[1])
        check(s == 401, f"another slot's token for observer N01: {method} {path} -> 401 (got {s})")
    s, r = req(B, "POST", "/api/answer", {"trial": 0, "answer": "seen"}, token=tokens[1])
    check(s == 409 and "start" in r.get("error", ""), "an unused link cannot answer before it starts -> 409")
    s, st = req(B, "GET", "/api/state?t=" + tokens[0], token="")
    check(s == 200 and st["observer"] == "N01", "the token also works as ?t= (for images)")
    for bad in ({"observer": "", "group": "naive"}, {"observer": "a b", "group": "naive"},
                {"observer": "x" * 65, "group": "naive"}, {"observer": "N02", "group": "student"},
                {"observer": 7, "group": "naive"}, {"group": "naive"}):
        s, _ = req(B, "POST", "/api/session", bad)
        check(s == 400, f"bad session {bad!r:.40} -> 400")
    # --- answers
    trials = plan["observers"][0]["trials"]
    given = []
    s, _ = req(B, "POST", "/api/answer", {"observer": "N01", "trial": 0, "answer": 3})
    check(s == 400, "calibration answered with a score -> 400")
    s, _ = req(B, "POST", "/api/answer", {"observer": "N01", "trial": 1, "answer": 3})
    check(s == 409, "answer to a later screen -> 409 (nothing skipped)")
    s, _ = req(B, "POST", "/api/answer", {"observer": "N01", "trial": 99, "answer": 3})
    check(s == 400, "trial outside the plan -> 400")
    s, _ = req(B, "POST", "/api/answer", {"observer": "ghost", "trial": 0, "answer": "seen"})
    check(s == 401, "an observer id that is not the link's -> 401")
    for i in range(4):
        a = answer_for(trials[i], rng)
        s, st = req(B, "POST", "/api/answer", {"observer": "N01", "trial": i, "answer": a,
                                                     "shown_at_ms": 1700000000000, "answered_at_ms": 1700000001234})
        check(s == 200 and st["trial"] == i + 1, f"answer {i} stored, next screen {i + 1}")
        given.append(a)
    s, st = req(B, "POST", "/api/answer", {"observer": "N01", "trial": 3, "answer": given[3]})
    check(s == 200 and st["trial"] == 4, "the same answer resent (lost reply) -> 200, stored once")
    other = 1 + (given[3] % 5) if trials[3]["kind"] == "likert" else "seen"
    s, _ = req(B, "POST", "/api/answer", {"observer": "N01", "trial": 3, "answer": other})
    check(s == 409, "a different answer to an answered screen -> 409, first answer kept")
    nxt = trials[4]
    s, _ = req(B, "POST", "/api/answer", {"observer": "N01", "trial": 4, "answer": 6 if nxt["kind"] == "likert" else "up"})
    check(s == 400, "out-of-range answer -> 400")
    # Screens 1-8 are Likert (--likert 8): a score is exactly an integer 1-5, never truncated
    # (get<int> once stored -4294967295 as 1 and 4294967299 as 3).
    check(nxt["kind"] == "likert", "screen 4 is a Likert screen")
    for bad in (-4294967295, 4294967299, 3.5, "3", 0, True, None, [3]):
        s, r = req(B, "POST", "/api/answer", {"observer": "N01", "trial": 4, "answer": bad})
        check(s == 400 and "Likert" in r.get("error", ""), f"Likert answer {bad!r} -> 400 (got {s})")
    for raw in (b'{"observer": "N01", "trial": 4, "answer": 1e999}', b'{"observer": "N01", "trial": 1e999, "answer": 3}',
                b'{"observer": "N01", "trial": 4, "answer": 3, "shown_at_ms": -1e999}'):
        s, r = req(B, "POST", "/api/answer", raw=raw)
        check(s == 400 and isinstance(r, dict) and r.get("error"), f"overflowing number {raw[-20:]!r} -> 400 with a message (got {s})")
    s, st = req(B, "GET", "/api/state?observer=N01")
    check(s == 200 and st["trial"] == 4, "refused answers stored nothing: N01 still at screen 4")
    # --- malformed requests
    for raw, code, what in ((b"{bad json", 400, "malformed JSON"), (b"[1,2]", 400, "JSON array"),
                            (b"x" * 100000, 413, "oversized body")):
        s, _ = req(B, "POST", "/api/answer", raw=raw)
        check(s == code, f"{what} -> {code} (got {s})")
    for path in ("/image/../../../etc/passwd", "/image/%2e%2e%2fstudy.json", "/image/-1", "/image/1e3",
                 "/image/99999999999", "/study.json", "/answers.sqlite", "/../study.json",
                 "/api/state?observer=../x", "/nope", "/answers.sqlite.links.txt"):
        s, body = req(B, "GET", path)
        check(400 <= s < 500 and b"root:" not in (body if isinstance(body, bytes) else b""), f"GET {path} -> {s}")
    s, body = req(B, "GET", "/image/0")
    with open(os.path.join(work, plan["images"][0]["file"]), "rb") as f:
        check(s == 200 and body == f.read(), "GET /image/0 serves the plan's first image")
    s, _ = req(B, "GET", "/")
    check(s == 200, "GET / serves the page")
    # --- Host, Origin, Content-Type (DNS rebinding and cross-site posts)
    import http.client

    def raw_request(method, path, headers, body=b""):
        host, port = B.rsplit("/", 1)[1].rsplit(":", 1)
        c = http.client.HTTPConnection(host, int(port), timeout=30)
        c.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
        for k, v in headers.items():
            c.putheader(k, v)
        if body:
            c.putheader("Content-Length", str(len(body)))
        c.endheaders(body)
        r = c.getresponse()
        data = r.read()
        c.close()
        return r.status, r.getheader("Access-Control-Allow-Origin"), data

    own = B.rsplit("/", 1)[1]
    ans = json.dumps({"observer": "N01", "trial": 4, "answer": 3}).encode()
    st_, cors, _ = raw_request("POST", "/api/answer", {"Host": own, "Origin": "http://evil.example",
                                                      "Content-Type": "text/plain"}, ans)
    check(st_ == 403 and cors is None, f"cross-origin text/plain POST -> 403, no CORS header (got {st_})")
    st_, _, _ = raw_request("POST", "/api/answer", {"Host": own, "Origin": "http://evil.example",
                                                    "Content-Type": "application/json"}, ans)
    check(st_ == 403, f"cross-origin JSON POST -> 403 (got {st_})")
    st_, _, _ = raw_request("POST", "/api/answer", {"Host": own, "Content-Type": "text/plain"}, ans)
    check(st_ == 415, f"text/plain POST -> 415 (got {st_})")
    for path in ("/", "/api/state?observer=N01", "/image/0"):
        st_, _, body_ = raw_request("GET", path, {"Host": "evil.example:" + own.rsplit(":", 1)[1]})
        check(st_ == 403, f"GET {path} with a foreign Host -> 403 (got {st_})")
    st_, _, _ = raw_request("GET", "/api/state?observer=N01", {})
    check(st_ == 403, f"no Host header -> 403 (got {st_})")
    st_, _, _ = raw_request("GET", "/api/state?observer=N01", {"Host": "localhost:" + own.rsplit(":", 1)[1],
                                                              "Origin": "http://localhost:" + own.rsplit(":", 1)[1],
                                                              "Authorization": "Bearer " + tokens[0]})
    check(st_ == 200, f"localhost alias with its own Origin -> 200 (got {st_})")
    s, st = req(B, "GET", "/api/state?observer=N01")
    check(s == 200 and st["trial"] == 4, "refused requests stored nothing: N01 still at screen 4")
    # --- slots
    for i, g in ((1, "expert"), (2, "naive")):
        s, st = req(B, "POST", "/api/session", {"observer": f"X{i}", "group": g}, token=tokens[i])
        check(s == 200 and st["observer"] == f"X{i}", f"observer X{i} starts with slot {i}'s link")
    s, st = req(B, "POST", "/api/session", {"observer": "X4", "group": "naive"}, token="")
    check(s == 401, "a 4th observer on a 3-slot plan has no link -> 401")
    con = sqlite3.connect(db)
    check(con.execute("SELECT observer, slot FROM observers ORDER BY slot").fetchall() == [("N01", 0), ("X1", 1), ("X2", 2)],
          "each observer sits in its link's slot")
    con.close()

    # --- a second server on the same port must not share it (SO_REUSEPORT would)
    r = fx.run(cli, "study", "serve", plan_path, "--db", os.path.join(work, "second.sqlite"), "--port",
               B.rsplit(":", 1)[1], check=False)
    check(r.returncode != 0 and r.stderr.startswith("error: ") and "cannot listen" in r.stderr,
          "a second server on a port in use is refused: " + r.stderr.strip())

    # --- SIGKILL mid-study: nothing acknowledged is lost, nothing asked twice
    srv.kill()
    port = B.rsplit(":", 1)[1]
    srv = fx.Server(cli, plan_path, db)
    B = srv.base
    check(srv.tokens == tokens, "a restarted server keeps the same links (tokens are in the database)")
    s, st = req(B, "GET", "/api/state?observer=N01")
    check(s == 200 and st["trial"] == 4, f"after SIGKILL and restart N01 resumes at screen 4 (got {st.get('trial')})")
    for i in range(4, len(trials)):
        a = answer_for(trials[i], rng)
        s, st = req(B, "POST", "/api/answer", {"observer": "N01", "trial": i, "answer": a})
        check(s == 200, f"answer {i} after restart")
        given.append(a)
    check(st["done"] is True and "screen" not in st, "observer done after the last screen")
    s, _ = req(B, "POST", "/api/answer", {"observer": "N01", "trial": len(trials), "answer": 3})
    check(s == 400, "answer after the end -> 400")
finally:
    code = srv.stop()
check(code == 0, f"SIGTERM stops the server cleanly (exit {code})")

rows = fx.db_rows(db, "N01")
check(rows == fx.expected_rows(plan, 0, given), "database holds exactly the answers given, in order, once each")
con = sqlite3.connect(db)
check(con.execute("PRAGMA journal_mode").fetchone()[0] == "wal", "database is in WAL mode")
t = con.execute("SELECT shown_at_ms, answered_at_ms, received_at FROM answers WHERE observer='N01' AND trial=1").fetchone()
check(t[0] == 1700000000000 and t[1] == 1700000001234 and t[2].endswith("Z"), "timestamps stored")
check(con.execute("SELECT DISTINCT grp FROM answers WHERE observer='N01'").fetchall() == [("naive",)],
      "every answer row carries the observer's group")
con.close()

# SIGINT and SIGTERM stop the server cleanly, also the instant it has started
# (a stop() before the server runs is kept, not lost).
import signal  # noqa: E402
import time  # noqa: E402
for sig in (signal.SIGINT, signal.SIGTERM):
    for delay in (0, 0.3):
        s2 = fx.Server(cli, plan_path, db)
        time.sleep(delay)
        s2.proc.send_signal(sig)
        try:
            rc = s2.proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            s2.kill()
            rc = None
        check(rc == 0, f"{signal.Signals(sig).name} {delay} s after start stops the server (exit {rc})")

# A database made for another plan is refused with one error line.
other_plan = os.path.join(work, "other.json")
fx.run(cli, "study", "plan", "--manifest", os.path.join(work, "images.json"), "-o", other_plan, "--seed", "99")
r = fx.run(cli, "study", "serve", other_plan, "--db", db, "--port", "0", check=False)
check(r.returncode != 0 and r.stderr.startswith("error: ") and r.stderr.count("\n") == 1 and "another plan" in r.stderr,
      "serving another plan's database is refused: " + r.stderr.strip())

# The database analyses directly.
r = fx.run(cli, "study", "analyze", db, "-o", os.path.join(work, "report"), check=False)
ok = r.returncode == 0
if ok:
    with open(os.path.join(work, "report", "stats.json")) as f:
        stats = json.load(f)
    n = sum(c["n_ratings"] for c in stats["all"]["categories"].values())
    ok = n == sum(1 for t in trials if t["kind"] == "likert") and stats["all"]["observers"] == ["N01"]
check(ok, "analyze reads the database: every Likert answer, the right observer " + r.stderr.strip()[:200])

# The study folder (plan, images, database) moves as a whole: files are relative.
moved = work + "_moved"
shutil.rmtree(moved, ignore_errors=True)
shutil.copytree(work, moved, ignore=shutil.ignore_patterns("report", "*.sqlite-*"))
shutil.rmtree(work + "_gone", ignore_errors=True)
os.rename(work, work + "_gone")  # the old location no longer exists
try:
    srv = fx.Server(cli, os.path.join(moved, "study.json"), os.path.join(moved, "answers.sqlite"))
    check(srv.tokens == tokens, "a moved study folder keeps its links")
    s, st = req(srv.base, "GET", "/api/state?observer=N01")
    s2, body = req(srv.base, "GET", "/image/0")
    check(s == 200 and st["done"] and s2 == 200 and len(body) > 100,
          "a moved study folder serves its images and resumes its database")
finally:
    srv.stop()
    os.rename(work + "_gone", work)

# A database from before the links (no slot_tokens table) migrates: its
# observers and answers stay, and every slot gets a token.
old = os.path.join(work, "old.sqlite")
shutil.copy(db, old)
con = sqlite3.connect(old)
con.execute("DROP TABLE slot_tokens")
con.commit()
con.close()
srv = fx.Server(cli, plan_path, old)
try:
    s, st = fx.request(srv.base, "GET", "/api/state", token=srv.tokens[0])
    check(len(set(srv.tokens)) == 3 and set(srv.tokens).isdisjoint(tokens) and s == 200 and st["observer"] == "N01"
          and st["done"], "a database without tokens gets new ones and keeps its observers and answers")
finally:
    srv.stop()

# --- hostile plan files: one `error: ... in <plan>: ...` line, non-zero exit, nothing served
with open(plan_path) as f:
    text = f.read()
key = '"series_length": '
at = text.index(key) + len(key)
end = min(text.index(c, at) for c in ",\n}" if c in text[at:])
for bad, what in (("0", "series length"), ("1e999", "not valid JSON"), ("-4294967295", "series_length")):
    edited = os.path.join(work, "edited.json")
    with open(edited, "w") as f:
        f.write(text[:at] + bad + text[end:])
    r = fx.run(cli, "study", "serve", edited, "--db", os.path.join(work, "edited.sqlite"), "--port", "0", check=False)
    lines = r.stderr.strip().splitlines()
    check(r.returncode != 0 and len(lines) == 1 and lines[0].startswith("error: ") and f"in {edited}:" in lines[0]
          and what in lines[0], f"plan with series_length {bad} refused: {r.stderr.strip()[:160]}")
p = json.loads(text)
p["images"][0]["file"] = "/etc/passwd"
with open(edited, "w") as f:
    json.dump(p, f)
r = fx.run(cli, "study", "serve", edited, "--db", os.path.join(work, "edited.sqlite"), "--port", "0", check=False)
check(r.returncode != 0 and r.stderr.startswith("error: ") and "plan's folder" in r.stderr,
      "a plan serving /etc/passwd as image 0 is refused: " + r.stderr.strip()[:160])

if failures:
    print(f"{len(failures)} check(s) failed")
    sys.exit(1)
print("all server checks passed")
