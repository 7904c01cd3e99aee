"""Host-port abuse benchmark (issue 9 item 3).

A cluster of its own (2 cards + 2 stations, default paced clock; card0 a Turbo card, as the DLS
clients expect, with `[host] max_connections` raised so that every abuser is really served):
a well-behaved dls-pmaclib client (PmacEthernetInterface) queries card0 on an idle card (the
baseline), then again while N concurrent connections abuse card0's ASCII and PMAC Ethernet
ports, in five equal groups:

- garbage:   random bytes, 256 at a time, every 20 ms;
- oversized: lines of 64 KiB without a <CR>, again and again;
- half-eth:  a PMAC Ethernet header announcing 1,400 bytes, 10 of them, then nothing;
- stall:     connected, silent;
- heavy:     the heaviest legal lines (`P0..8191` ten times on one line, Ethernet and ASCII),
             the reply read slowly (4 KiB every 50 ms).

An abuser the card closes (a timeout, an eviction, a refused line) connects again at once.
Reported: the client's round trips (p50/p99/max) idle and under abuse, whether every reply was
right, the card's resident memory (before, peak), the ring (cycles advanced, ring faults) and
what the abusers got (connections, closes, bytes).

    python tests/clients/abuse.py [--connections 500] [--seconds 30] [--queries 400] [--json]

Exits 1 if the client was not served right, or the ring latched a fault.
"""

import argparse
import asyncio
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import multiprocessing
import threading
import time
from pathlib import Path

from dls_pmaclib.dls_pmacremote import PmacEthernetInterface

ROOT = Path(__file__).resolve().parents[2]
MCC = os.environ.get("MCC_BIN", str(ROOT / "target" / "debug" / "mcc"))
KINDS = ["garbage", "oversized", "half-eth", "stall", "heavy"]
HEAVY = " ".join(["P0..8191"] * 10)


def mcc(env, *args, timeout=120):
    return subprocess.run(
        [MCC, *args], env=env, capture_output=True, text=True, timeout=timeout, check=False
    )


class Cluster:
    """`mcc up --detach` of a cluster of its own (its own run directory), `down` at the end."""

    def __init__(self, max_connections):
        self.dir = tempfile.mkdtemp(prefix="mcc-abuse-")
        self.env = dict(os.environ, MCC_RUN_DIR=self.dir, MCC_LOG="warn")
        self.name = f"abuse-{os.getpid()}"
        cfg = mcc(self.env, "up", "--print-config").stdout
        # card0 a Turbo card: its ring check variables are I80/I81/I82 (PMAC2 I1001/4/5).
        cfg = cfg.replace('profile = "pmac2"', 'profile = "turbo"', 1)
        cfg = cfg.replace("I1001 = 16\nI1004 = 2\nI1005 = 4", "I80 = 16\nI81 = 2\nI82 = 4", 1)
        cfg = cfg.replace("max_connections = 64", f"max_connections = {max_connections}")
        path = Path(self.dir) / "abuse.toml"
        path.write_text(cfg)
        up = mcc(
            self.env, "up", "--detach", "--json", "--cluster", self.name, "--config", str(path),
            "--owner-pid", str(os.getpid()), timeout=180,
        )
        if up.returncode != 0:
            shutil.rmtree(self.dir, ignore_errors=True)
            raise RuntimeError(f"mcc up: {up.stdout}{up.stderr}")
        doc = self.status()
        card = doc["cards"][0]
        self.eth, self.ascii, self.pid = card["pmac_eth"], card["ascii"], card["pid"]

    def status(self):
        out = mcc(self.env, "status", "--json", "--cluster", self.name)
        return json.loads(out.stdout)

    def down(self):
        mcc(self.env, "down", "--cluster", self.name)
        shutil.rmtree(self.dir, ignore_errors=True)


def rss_kb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def percentile(v, p):
    if not v:
        return None
    v = sorted(v)
    return v[min(len(v) - 1, int(round(p / 100 * (len(v) - 1))))]


def client_run(port, queries, stop=None):
    """The well-behaved host: `P1=k P1` round trips; (round trips in ms, wrong replies)."""
    pmac = PmacEthernetInterface(timeout=30.0)
    pmac.setConnectionParams("127.0.0.1", port)
    err = pmac.connect()
    if err is not None:
        return [], [f"connect: {err}"]
    rtts, wrong = [], []
    try:
        for k in range(queries):
            if stop is not None and stop.is_set():
                break
            t0 = time.perf_counter()
            reply, ok = pmac.sendCommand(f"P1={k} P1")
            rtts.append((time.perf_counter() - t0) * 1e3)
            if not ok or reply != f"{k}\r\x06":
                wrong.append(f"P1={k} P1 -> {reply!r} ({ok})")
    finally:
        pmac.disconnect()
    return rtts, wrong


def summary(rtts):
    return {
        "n": len(rtts),
        "p50_ms": percentile(rtts, 50),
        "p99_ms": percentile(rtts, 99),
        "max_ms": max(rtts) if rtts else None,
    }


async def abuser(kind, port_eth, port_ascii, stop, stats):
    rng = random.Random(hash(kind) ^ id(stats))
    eth = kind in ("half-eth",) or (kind == "heavy" and rng.random() < 0.5)
    port = port_eth if eth else port_ascii
    while not stop.is_set():
        try:
            r, w = await asyncio.open_connection("127.0.0.1", port)
        except OSError:
            stats["connect_failed"] += 1
            await asyncio.sleep(0.05)
            continue
        stats["connections"] += 1
        try:
            if kind == "garbage":
                while not stop.is_set():
                    w.write(os.urandom(256))
                    await w.drain()
                    stats["sent"] += 256
                    await asyncio.sleep(0.02)
                    await drain_replies(r, stats)
            elif kind == "oversized":
                while not stop.is_set():
                    w.write(b"P1" * 32768)
                    await w.drain()
                    stats["sent"] += 65536
                    await drain_replies(r, stats)
                    await asyncio.sleep(0.1)
            elif kind == "half-eth":
                w.write(bytes([0x40, 0xBF, 0, 0, 0, 0, 0x05, 0x78]) + b"P1 P2 P3 ")
                await w.drain()
                stats["sent"] += 17
                await wait_closed(r, stop, stats)
            elif kind == "stall":
                await wait_closed(r, stop, stats)
            else:
                while not stop.is_set():
                    if eth:
                        n = len(HEAVY)
                        w.write(bytes([0x40, 0xBF, 0, 0, 0, 0, n >> 8, n & 0xFF]) + HEAVY.encode())
                    else:
                        w.write(HEAVY.encode() + b"\r")
                    await w.drain()
                    stats["sent"] += len(HEAVY)
                    # Read the reply slowly: 4 KiB every 50 ms until its end (or a while).
                    for _ in range(400):
                        if stop.is_set():
                            break
                        chunk = await asyncio.wait_for(r.read(4096), 5.0)
                        if not chunk:
                            raise ConnectionResetError
                        stats["received"] += len(chunk)
                        if chunk.endswith(b"\x06") or chunk.endswith(b"\r\x07") or (
                            b"\x07" in chunk
                        ):
                            break
                        await asyncio.sleep(0.05)
        except (OSError, asyncio.TimeoutError, ConnectionResetError):
            pass
        finally:
            stats["closed"] += 1
            w.close()


async def drain_replies(r, stats):
    try:
        chunk = await asyncio.wait_for(r.read(65536), 0.001)
    except asyncio.TimeoutError:
        return
    if not chunk:
        raise ConnectionResetError
    stats["received"] += len(chunk)


async def wait_closed(r, stop, stats):
    while not stop.is_set():
        try:
            chunk = await asyncio.wait_for(r.read(4096), 0.5)
        except asyncio.TimeoutError:
            continue
        if not chunk:
            return
        stats["received"] += len(chunk)


def run_abusers(n, eth, asc, stop, out, ready):
    """The abusers, in a process of their own (the client's round trips must not wait for
    this process's interpreter)."""
    stats = {
        k: {"connections": 0, "closed": 0, "connect_failed": 0, "sent": 0, "received": 0}
        for k in KINDS
    }

    async def main():
        tasks = [
            asyncio.create_task(abuser(KINDS[i % len(KINDS)], eth, asc, stop, stats[KINDS[i % len(KINDS)]]))
            for i in range(n)
        ]
        ready.set()
        while not stop.is_set():
            await asyncio.sleep(0.1)
        await asyncio.sleep(0.5)
        for t in tasks:
            t.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    asyncio.run(main())
    out.put(stats)


def bench(connections=500, seconds=30.0, queries=400):
    cluster = Cluster(max_connections=connections + 64)
    try:
        before = cluster.status()
        rss_before = rss_kb(cluster.pid)
        idle, idle_wrong = client_run(cluster.eth, queries)
        stop = multiprocessing.Event()
        ready = multiprocessing.Event()
        out = multiprocessing.Queue()
        th = multiprocessing.Process(
            target=run_abusers, args=(connections, cluster.eth, cluster.ascii, stop, out, ready)
        )
        th.start()
        ready.wait(30)
        peak = [rss_kb(cluster.pid)]

        def sample():
            while not stop.is_set():
                peak[0] = max(peak[0], rss_kb(cluster.pid))
                time.sleep(0.25)

        sampler = threading.Thread(target=sample)
        sampler.start()
        time.sleep(min(2.0, seconds / 4))  # let every abuser connect
        t0 = time.monotonic()
        loaded, loaded_wrong = [], []
        while time.monotonic() - t0 < seconds:
            r, w = client_run(cluster.eth, queries)
            loaded += r
            loaded_wrong += w
            if w:
                break
        stop.set()
        stats = out.get(timeout=60)
        th.join(60)
        sampler.join(5)
        after = cluster.status()
        faults = [
            m["name"]
            for m in after["members"]
            if m.get("ring_fault") or m.get("ring_fault_count", 0) > next(
                (b.get("ring_fault_count", 0) for b in before["members"] if b["name"] == m["name"]),
                0,
            )
        ]
        report = {
            "connections": connections,
            "seconds": seconds,
            "client_idle": summary(idle),
            "client_under_abuse": summary(loaded),
            "wrong_replies": idle_wrong + loaded_wrong,
            "card_rss_mb": {"before": rss_before // 1024, "peak": peak[0] // 1024},
            "ring": {
                "cycles": after["ring"]["cycle"] - before["ring"]["cycle"],
                "faulted": after["ring"]["faulted"],
                "members_with_new_ring_fault": faults,
            },
            "abusers": stats,
        }
        return report
    finally:
        cluster.down()


def text(r):
    i, l = r["client_idle"], r["client_under_abuse"]
    lines = [
        f"host-port abuse: {r['connections']} connections on card0 for {r['seconds']:.0f} s",
        f"  dls-pmaclib client idle:        n {i['n']}, p50 {i['p50_ms']:.2f} ms, p99 {i['p99_ms']:.2f} ms, max {i['max_ms']:.2f} ms",
        f"  dls-pmaclib client under abuse: n {l['n']}, p50 {l['p50_ms']:.2f} ms, p99 {l['p99_ms']:.2f} ms, max {l['max_ms']:.2f} ms"
        f" (p99 ratio {l['p99_ms'] / i['p99_ms']:.1f}x)",
        f"  wrong replies: {len(r['wrong_replies'])}",
        f"  card0 RSS: {r['card_rss_mb']['before']} MB before, {r['card_rss_mb']['peak']} MB peak",
        f"  ring: {r['ring']['cycles']} cycles during the run, faulted {r['ring']['faulted']}, "
        f"new ring faults {r['ring']['members_with_new_ring_fault'] or 'none'}",
    ]
    for k, s in r["abusers"].items():
        lines.append(
            f"  {k:<10} connections {s['connections']:>6}  ended {s['closed']:>6}  "
            f"refused {s['connect_failed']:>5}  sent {s['sent'] // 1024:>8} KiB  received {s['received'] // 1024:>8} KiB"
        )
    return "\n".join(lines)


def failed(r):
    return bool(
        r["wrong_replies"]
        or r["client_under_abuse"]["n"] == 0
        or r["ring"]["faulted"]
        or r["ring"]["members_with_new_ring_fault"]
        or r["ring"]["cycles"] <= 0
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--connections", type=int, default=500)
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--queries", type=int, default=400)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    r = bench(a.connections, a.seconds, a.queries)
    print(json.dumps(r, indent=2) if a.json else text(r))
    sys.exit(1 if failed(r) else 0)


if __name__ == "__main__":
    main()
