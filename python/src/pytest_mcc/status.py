"""The ``mcc status --json`` document (a contract: architecture §6) with a few accessors, and
a stream of them (``mcc status --json --watch MS``) for waits measured in ring cycles."""

from __future__ import annotations

import json
import subprocess
import threading
import time
from typing import Any, Dict, List, Optional

from .errors import MccError, UnknownChoice


class StatusTimeout(MccError, TimeoutError):
    """No status document arrived in time."""


class Status(dict):
    """One status document. It is the parsed JSON (``status["ring"]["cycle"]``) with
    shortcuts for what tests ask most."""

    @property
    def cycle(self) -> int:
        """Ring cycle of the synchronizing master."""
        return int(self["ring"]["cycle"])

    @property
    def locked(self) -> bool:
        """Every member alive and phase-locked."""
        return bool(self["ring"]["locked"])

    @property
    def faulted(self) -> bool:
        """A member latched a ring fault, or a link is broken."""
        return bool(self["ring"]["faulted"])

    @property
    def broken_link(self) -> Optional[str]:
        """The broken link (``"station0 → card1"``), or None."""
        return self["ring"].get("broken_link")

    @property
    def member_names(self) -> List[str]:
        """Members in ring order."""
        return [m["name"] for m in self["members"]]

    def member(self, name: str) -> Dict[str, Any]:
        """The row of member ``name`` (raises :class:`UnknownChoice` naming the members)."""
        for m in self["members"]:
            if m["name"] == name:
                return m
        raise UnknownChoice("member", name, self.member_names)

    def card(self, number: int) -> Dict[str, Any]:
        """The ``cards[]`` row of card ``number`` (I0)."""
        for c in self["cards"]:
            if c["number"] == number:
                return c
        raise UnknownChoice("card", number, [c["number"] for c in self["cards"]])

    def ring_faulted_cards(self) -> List[int]:
        """Numbers of the cards whose ring-fault bit is set."""
        return [c["number"] for c in self["cards"] if c.get("ring_fault")]

    def summary(self) -> str:
        """One line for a failure message: the ring, each member (alive, locked, dark,
        latched ring fault with its reason, injected faults) and each card's ring-fault bit
        (``?`` when the card's info went unanswered)."""
        ring = self.get("ring", {})
        parts = [f"cycle {ring.get('cycle')}: locked={ring.get('locked')} "
                 f"faulted={ring.get('faulted')} broken_link={ring.get('broken_link')}"]
        for m in self.get("members", []):
            flags = []
            if not m.get("alive"):
                flags.append("dead")
            if m.get("slow"):
                flags.append("slow")
            flags.append("locked" if m.get("locked") else "unlocked")
            if m.get("dark"):
                flags.append(f"dark since {m.get('dark_since_cycle')}")
            if m.get("ring_fault"):
                flags.append(f"ring fault at {m.get('ring_fault_cycle')} "
                             f"({m.get('fault_reason')})")
            kinds = [f.get("kind") for f in m.get("faults") or []]
            if kinds:
                flags.append("injected " + "+".join(str(k) for k in kinds))
            flags.append(f"cycle {m.get('cycle')} rx {m.get('last_rx_cycle')}")
            parts.append(f"{m.get('name')}: " + ", ".join(flags))
        bits = []
        for c in self.get("cards", []):
            rf = c.get("ring_fault")
            bits.append(f"{c.get('number')}={'?' if rf is None else int(bool(rf))}")
        if bits:
            parts.append("card ring-fault bits " + " ".join(bits))
        return "; ".join(parts)


class StatusStream:
    """A running ``mcc status --json --watch MS``: the newest document, and waiting for the
    next one. Stopped by :meth:`close` (the process also ends when its reader dies)."""

    def __init__(self, argv: List[str], env: Dict[str, str]) -> None:
        self._proc = subprocess.Popen(argv, env=env, stdin=subprocess.DEVNULL,
                                      stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                      text=True, bufsize=1)
        self._cond = threading.Condition()
        self._latest: Optional[Status] = None
        self._seq = 0
        self._ended = False
        self._thread = threading.Thread(target=self._read, name="mcc-status-watch",
                                        daemon=True)
        self._thread.start()

    def _read(self) -> None:
        assert self._proc.stdout is not None
        try:
            for line in self._proc.stdout:
                try:
                    doc = json.loads(line)
                except ValueError:
                    continue
                if not isinstance(doc, dict) or "ring" not in doc:
                    continue
                with self._cond:
                    self._latest = Status(doc)
                    self._seq += 1
                    self._cond.notify_all()
        except (ValueError, OSError):
            pass  # the pipe was closed by close()
        with self._cond:
            self._ended = True
            self._cond.notify_all()

    @property
    def alive(self) -> bool:
        """The watch process still runs."""
        return self._proc.poll() is None and not self._ended

    def next(self, timeout: float) -> Status:
        """The first document that arrives after this call (waits up to ``timeout`` s)."""
        deadline = time.monotonic() + timeout
        with self._cond:
            seq = self._seq
            while self._seq == seq:
                if self._ended:
                    err = self._proc.stderr.read() if self._proc.stderr else ""
                    raise MccError(f"mcc status --watch ended: {err.strip()}", stderr=err)
                left = deadline - time.monotonic()
                if left <= 0:
                    raise StatusTimeout(f"no status document within {timeout:.1f} s")
                self._cond.wait(left)
            assert self._latest is not None
            return self._latest

    def close(self) -> None:
        """Stop the watch process (idempotent)."""
        if self._proc.poll() is None:
            self._proc.terminate()
            try:
                self._proc.wait(5)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
        for f in (self._proc.stdout, self._proc.stderr):
            try:
                if f:
                    f.close()
            except Exception:  # noqa: BLE001 - closing a pipe of a dead process
                pass
