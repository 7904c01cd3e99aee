"""Process bookkeeping for teardown: which pids a cluster had, and killing what is left of
them without ever touching a process that merely reused a pid."""

from __future__ import annotations

import os
import signal
import time
from typing import Dict, Iterable, Optional


def start_time(pid: int) -> Optional[int]:
    """Start time of ``pid`` (field 22 of /proc/<pid>/stat), None if it does not run."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat = f.read().decode("ascii", "replace")
    except OSError:
        return None
    rest = stat[stat.rfind(")") + 1:].split()
    if not rest or rest[0] in ("Z", "X"):
        return None
    try:
        return int(rest[19])
    except (IndexError, ValueError):
        return None


class Tracked:
    """Pids seen in a cluster's status, each with its start time when first seen."""

    def __init__(self) -> None:
        self._pids: Dict[int, Optional[int]] = {}

    def add(self, pids: Iterable[Optional[int]]) -> None:
        """Remember these pids (None entries ignored)."""
        for p in pids:
            if p and p not in self._pids:
                self._pids[int(p)] = start_time(int(p))

    def alive(self) -> list:
        """The remembered processes that still run (same pid, same start time)."""
        return [p for p, t in self._pids.items() if t is not None and start_time(p) == t]

    def kill_all(self, wait: float = 5.0) -> list:
        """SIGKILL every remembered process still running; the pids that were killed."""
        left = self.alive()
        for p in left:
            try:
                os.kill(p, signal.SIGKILL)
            except OSError:
                pass
        deadline = time.monotonic() + wait
        while self.alive() and time.monotonic() < deadline:
            time.sleep(0.05)
        return left
