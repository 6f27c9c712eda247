"""`mucosa study serve` under abuse, on loopback only, bounded in count and time
(about 30 s): slowloris connections, an endless chunked body, oversized
headers. The server must keep answering a real observer, close the abusive
connections at its limits, and keep its memory bounded.

Usage: abuse_test.py MUCOSA_CLI WORK_DIR
"""
import os
import shutil
import socket
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import study_fixture as fx  # noqa: E402

cli, work = sys.argv[1], sys.argv[2]
SLOW = 200                 # slowloris connections
SLOW_FROM = "127.0.0.2"    # Linux routes all of 127/8 to lo: another client address
DEADLINE_S = 10            # the server's whole-request deadline (server.cpp, kRequestDeadline)
OBSERVER_MAX_S = 1.0       # every answer of the real observer within this
RSS_CEILING_MB = 200       # the server's peak resident memory during the chunked attack
CHUNKED_MAX = 1 << 30      # the attacker stops at 1 GiB, or when the server closes
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
plan_path, plan = fx.make_plan(cli, work, observers=3, extra=("--likert", "30", "--twoafc", "2"))
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def rss_kb(pid, key="VmRSS"):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return 0


class Observer:
    """A real observer from 127.0.0.1 answering screen after screen."""

    def __init__(self, base, token, oid):
        self.base, self.token, self.oid = base, token, oid
        s, self.st = fx.request(base, "POST", "/api/session", {"observer": oid, "group": "naive"}, token=token)
        if s != 200:
            raise RuntimeError(f"session: {s} {self.st}")
        self.latencies = []

    def step(self):
        """Fetches the screen's image and answers it; returns the slower of the two times."""
        st = self.st
        if st["done"]:
            return None
        sc = st["screen"]
        t0 = time.perf_counter()
        s, _ = fx.request(self.base, "GET", sc.get("image") or sc["left"], token=self.token, timeout=10)
        t_image = time.perf_counter() - t0
        a = {"calibration": "seen", "likert": 3, "twoafc": "left"}[sc["kind"]]
        t0 = time.perf_counter()
        s2, nxt = fx.request(self.base, "POST", "/api/answer", {"trial": st["trial"], "answer": a},
                             token=self.token, timeout=10)
        t_answer = time.perf_counter() - t0
        if s != 200 or s2 != 200:
            raise RuntimeError(f"screen {st['trial']}: image {s}, answer {s2} {nxt}")
        self.st = nxt
        self.latencies.append(max(t_image, t_answer))
        return self.latencies[-1]


def slowloris(port, n):
    """n connections from SLOW_FROM, each sending its header one byte a second.
    Returns [(opened_at, closed_at or None)] after every one is closed or 1.5 x the deadline passed."""
    socks, opened = [], []
    for _ in range(n):
        c = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        c.bind((SLOW_FROM, 0))
        c.settimeout(5)
        c.connect(("127.0.0.1", port))
        c.setblocking(False)
        socks.append(c)
        opened.append(time.monotonic())
    closed = [None] * n
    head = f"GET /api/state HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nX-Slow: ".encode()
    sent = [0] * n
    end = time.monotonic() + 1.5 * DEADLINE_S
    while time.monotonic() < end and None in closed:
        for i, c in enumerate(socks):
            if closed[i] is not None:
                continue
            try:
                if c.recv(1, socket.MSG_PEEK) == b"":  # orderly close
                    closed[i] = time.monotonic()
                    continue
            except BlockingIOError:
                pass
            except OSError:
                closed[i] = time.monotonic()
                continue
            try:
                c.send(head[sent[i]:sent[i] + 1] if sent[i] < len(head) else b"a")
                sent[i] += 1
            except BlockingIOError:
                pass
            except OSError:
                closed[i] = time.monotonic()
        time.sleep(0.1 if time.monotonic() - min(opened) < 1 else 1.0)  # a byte a second after the first
    for c in socks:
        c.close()
    return list(zip(opened, closed))


# --- 1. slowloris: 200 slow connections, every one accepted (the per-address cap raised)
srv = fx.Server(cli, plan_path, os.path.join(work, "a.sqlite"), extra=("--client-connections", "1000"))
port = int(srv.base.rsplit(":", 1)[1])
try:
    obs = Observer(srv.base, srv.tokens[0], "REAL1")
    result = []
    t = threading.Thread(target=lambda: result.extend(slowloris(port, SLOW)))
    t0 = time.monotonic()
    t.start()
    time.sleep(1.5)  # all 200 open and trickling
    during = []
    while t.is_alive() and time.monotonic() - t0 < DEADLINE_S - 1 and not obs.st["done"]:
        during.append(obs.step())
        time.sleep(0.3)
    t.join()
    slow_open = sum(1 for o, c in result if c is None or c - o > 1)
    check(len(during) >= 10 and max(during) < OBSERVER_MAX_S,
          f"with {SLOW} slowloris connections open, {len(during)} observer screens answered, "
          f"slowest {1000 * max(during):.0f} ms (limit {1000 * OBSERVER_MAX_S:.0f} ms)")
    check(slow_open == SLOW, f"all {SLOW} slow connections were accepted and held ({slow_open})")
    lifetimes = sorted(c - o for o, c in result if c is not None)
    check(len(lifetimes) == SLOW and DEADLINE_S - 1 <= lifetimes[0] and lifetimes[-1] <= DEADLINE_S + 3,
          f"the server closed every slow connection at its {DEADLINE_S} s deadline "
          f"({len(lifetimes)} closed, after {lifetimes[0]:.1f}-{lifetimes[-1]:.1f} s)" if lifetimes else "none closed")
    s, _ = fx.request(srv.base, "GET", "/api/state", token=srv.tokens[0])
    check(s == 200, "serving after the slowloris connections")
finally:
    code = srv.stop()
check(code == 0, f"SIGTERM stops the server after the slowloris run (exit {code})")

# --- 2. the same from one address with the default cap: the excess is closed at once
srv = fx.Server(cli, plan_path, os.path.join(work, "b.sqlite"))
port = int(srv.base.rsplit(":", 1)[1])
try:
    obs = Observer(srv.base, srv.tokens[0], "REAL2")
    held = []
    for _ in range(SLOW):
        c = socket.socket()
        c.bind((SLOW_FROM, 0))
        c.settimeout(5)
        c.connect(("127.0.0.1", port))
        c.send(b"GET / HTTP/1.1\r\n")
        held.append(c)
    time.sleep(1.0)
    closed_now = 0
    for c in held:
        c.settimeout(0.01)
        try:
            closed_now += c.recv(1) == b""
        except socket.timeout:
            pass
        except OSError:
            closed_now += 1
    check(closed_now == SLOW - 64, f"{SLOW} connections from {SLOW_FROM}: {closed_now} closed at once, 64 held")
    lat = [obs.step() for _ in range(5)]
    check(max(lat) < OBSERVER_MAX_S, f"meanwhile 127.0.0.1 is served: slowest of 5 screens {1000 * max(lat):.0f} ms")
    for c in held:
        c.close()

    # --- 3. chunked attack: an endless chunked answer body, far beyond the 16 KiB limit
    samples = []
    stop_sampling = threading.Event()

    def sample():
        while not stop_sampling.is_set():
            samples.append(rss_kb(srv.proc.pid))
            time.sleep(0.05)

    sampler = threading.Thread(target=sample)
    sampler.start()
    c = socket.create_connection(("127.0.0.1", port), timeout=5)
    c.sendall(f"POST /api/answer HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Type: application/json\r\n"
              f"Authorization: Bearer {srv.tokens[1]}\r\nTransfer-Encoding: chunked\r\n\r\n".encode())
    chunk = b"10000\r\n" + b" " * 0x10000 + b"\r\n"
    sent, t0 = 0, time.monotonic()
    try:
        while sent < CHUNKED_MAX and time.monotonic() - t0 < 20:
            c.sendall(chunk)
            sent += 0x10000
    except OSError:
        pass
    elapsed = time.monotonic() - t0
    reply = b""
    try:
        c.settimeout(2)
        reply = c.recv(200)
    except OSError:
        pass
    c.close()
    stop_sampling.set()
    sampler.join()
    peak = max(samples) / 1024
    status = reply.split(b"\r\n", 1)[0].decode(errors="replace")
    check(sent < 64 << 20 and elapsed < 10, f"the server stopped the chunked body after {sent >> 20} MiB "
          f"of a {CHUNKED_MAX >> 30} GiB attempt, in {elapsed:.1f} s (reply: {status or 'closed'})")
    check(status in ("", "HTTP/1.1 413 Payload Too Large"), "the chunked attacker got 413 or a closed connection")
    check(peak < RSS_CEILING_MB, f"server RSS during the chunked attack: peak {peak:.1f} MiB "
          f"(ceiling {RSS_CEILING_MB} MiB; VmHWM {rss_kb(srv.proc.pid, 'VmHWM') / 1024:.1f} MiB)")

    # --- 4. a declared 1 GiB body and a 9 KiB header are refused up front
    c = socket.create_connection(("127.0.0.1", port), timeout=5)
    c.sendall(f"POST /api/answer HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Type: application/json\r\n"
              f"Content-Length: {1 << 30}\r\n\r\n".encode())
    reply = c.recv(200)
    c.close()
    check(reply.startswith(b"HTTP/1.1 413"), f"Content-Length 1 GiB -> 413 before any body ({reply[:20]!r})")
    c = socket.create_connection(("127.0.0.1", port), timeout=5)
    c.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nX-Big: {'a' * 9000}\r\n\r\n".encode())
    reply = c.recv(200)
    c.close()
    check(reply.startswith(b"HTTP/1.1 431"), f"a 9 KiB header -> 431 ({reply[:20]!r})")
    lat = [obs.step() for _ in range(3)]
    check(max(lat) < OBSERVER_MAX_S, f"still serving the observer afterwards: slowest {1000 * max(lat):.0f} ms")
finally:
    code = srv.stop()
check(code == 0, f"SIGTERM stops the server after the attacks (exit {code})")

if failures:
    print(f"{len(failures)} check(s) failed")
    sys.exit(1)
print("all abuse checks passed")
