"""Wall-clock benchmark of the default (paced) cluster through dls-pmaclib (issue 8).

What a host author sees on the wall clock when the default cluster runs motion: a LINEAR
move of 10 units at F5 with TA200 (10/5 s + 0.2 s = 2.2 s on a PMAC), a jog of 10,000 counts
at I122 = 32 counts/ms (0.3125 s + I120 = 50 ms of acceleration), and a home search. Each is timed
from the command's reply to the motor settling, polling the card through dls-pmaclib's
PmacEthernetInterface as host software does; the report gives each run, their mean and the
ratio to the PMAC's time. Ring time is asserted in the scenario tests; this is the wall-clock
side, so it prints and never fails on speed (it fails only if the cluster does not work).

Run: bash tests/clients/bench.sh [--repeat N] [--cards C --stations S] [--rtf X]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from typing import Callable, List, Tuple

from pytest_mcc import Cluster

LINEAR_S = 10 / 5 + 0.2  # LINEAR ABS TA200 TS0 F5, X10 with #1->1000X


def word2(reply: str) -> int:
    digits = "".join(c for c in reply if c in "0123456789abcdefABCDEF")
    return int(digits[6:12], 16)


def number(reply: str) -> float:
    return float(reply.strip().split()[0])


class Host:
    """A dls-pmaclib connection with a checked `send`."""

    def __init__(self, pmac) -> None:
        self.pmac = pmac

    def send(self, line: str) -> str:
        reply, ok = self.pmac.sendCommand(line)
        if not ok or "\x07" in reply:
            raise RuntimeError(f"{line!r} refused: {reply!r}")
        return reply

    def position(self) -> float:
        return number(self.send("#1P"))

    def settled_at(self, target: float, tol: float, timeout: float) -> Tuple[float, float]:
        """Poll until motor 1 is in position within `tol` of `target`: (first-motion time,
        settle time), both time.monotonic()."""
        start = self.position()
        moved = None
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            p = self.position()
            now = time.monotonic()
            if moved is None and abs(p - start) > tol:
                moved = now
            if abs(p - target) <= tol and word2(self.send("#1?")) & 1:
                return (moved if moved is not None else now), now
            time.sleep(0.002)
        raise RuntimeError(f"motor 1 did not settle at {target} within {timeout} s (at {p})")


def timed(label: str, runs: List[float], expect: float) -> str:
    mean = statistics.mean(runs)
    spread = ", ".join(f"{r:.3f}" for r in runs)
    return (f"{label:<44} mean {mean:.3f} s (runs {spread}); PMAC {expect:.3f} s; "
            f"ratio {mean / expect:.3f}")


def main(argv: List[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--cards", type=int, default=2)
    ap.add_argument("--stations", type=int, default=2)
    ap.add_argument("--rtf", type=float, default=None)
    a = ap.parse_args(argv)
    extra = {"rtf": a.rtf} if a.rtf is not None else None
    t_up = time.monotonic()
    with Cluster(cards=a.cards, stations=a.stations, extra=extra) as c:
        up = time.monotonic() - t_up
        st = c.status()
        h = Host(c.card(0).pmaclib())
        print(f"cluster: {a.cards} cards + {a.stations} stations, clock {st['clock']}, "
              f"rtf requested {st.get('rtf_requested')}; up and locked in {up:.2f} s")
        tol = 5.0
        # Jog 0 -> 10000 -> 0 counts at I122 = 32 counts/ms, I120 = 50 ms acceleration, no
        # S-curve (I121 = 0), and I119 high enough not to govern (with the default I119 =
        # 0.015625 counts/ms^2 the ramp takes 800 ms each way, as on a PMAC).
        h.send("I119=10 I122=32 I121=0 I120=50")
        jog_s = 10000 / 32 / 1000 + 0.050
        jogs = []
        for i in range(a.repeat):
            target = 10000.0 if i % 2 == 0 else 0.0
            h.send(f"#1J={int(target)}")
            moved, done = h.settled_at(target, tol, 60.0)
            jogs.append(done - moved)
        # Home search from 10000 counts down onto the plant's home switch (5000-6000).
        h.send("#1J=10000")
        h.settled_at(10000.0, tol, 60.0)
        t0 = time.monotonic()
        h.send("I123=-32 #1HM")
        deadline = time.monotonic() + 120.0
        while not (word2(h.send("#1?")) & 0x401) == 0x401:
            if time.monotonic() > deadline:
                raise RuntimeError("home search did not complete in 120 s")
            time.sleep(0.005)
        home_s = time.monotonic() - t0
        # LINEAR X10 at F5 TA200 (X0 between runs).
        for line in ["&1#1->1000X", "OPEN PROG 2 CLEAR", "LINEAR ABS TA200 TS0 F5", "X10",
                     "CLOSE", "OPEN PROG 3 CLEAR", "LINEAR ABS TA200 TS0 F5", "X0",
                     "CLOSE"]:
            h.send(line)
        moves, walls, rings = [], [], []
        rate = float(c.config.get("rate_hz", 2258.7))
        for i in range(a.repeat):
            prog, target = (2, 10000.0) if i % 2 == 0 else (3, 0.0)
            c0, t0 = c.status().cycle, time.monotonic()
            h.send(f"&1B{prog}R")
            moved, done = h.settled_at(target, tol, 60.0)
            c1, t1 = c.status().cycle, time.monotonic()
            moves.append(done - moved)
            walls.append(t1 - t0)
            rings.append((c1 - c0) / rate)
        st = c.status()
        print(timed("LINEAR X10 F5 TA200 (first motion to settle)", moves, LINEAR_S))
        print(timed("#1J= 10000 counts at 32 cts/ms (same)", jogs, jog_s))
        print(f"{'#1HM from 10000 down onto the home switch':<44} {home_s:.3f} s (plant-dependent)")
        print(f"{'same moves, status to status':<44} wall {sum(walls):.3f} s, ring time "
              f"{sum(rings):.3f} s (cycles / rate_hz): ring time per wall second "
              f"{sum(rings) / sum(walls):.3f}")
        print(f"achieved rtf {st.get('rtf')}, late cycles {st.get('late_cycles')}, "
              f"ring faulted {st['ring']['faulted']}")
        inside = abs(statistics.mean(moves) - LINEAR_S) <= 0.15
        print(f"LINEAR move within 2.2 s +/- 0.15 s: {'yes' if inside else 'NO'}")
        if st["ring"]["faulted"]:
            print("ring faulted during the benchmark", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
