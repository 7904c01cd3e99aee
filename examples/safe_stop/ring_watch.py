"""A host-side "safe stop" routine, as a beamline's control software might have one: it
watches every controller's global status and, the moment one reports a MACRO ring fault,
aborts motion on every controller (CTRL-A) and reports which one faulted.

It talks to the controllers through any object with ``sendCommand(line) -> (reply, ok)``
(a dls-pmaclib interface, here over the PMAC Ethernet protocol).
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional

#: Global status word 1 (X:$0003), bit 4: MACRO ring check error.
RING_FAULT_BIT = 1 << 4


@dataclass
class RingFaultReport:
    """What the routine reports."""

    controller: str
    global_status: str
    stopped: List[str]
    at: float  # time.monotonic() of the report


def ring_fault(global_status: str) -> bool:
    """Whether a ``???`` reply (12 hex digits: word 1 then word 2) has the ring-fault bit."""
    digits = "".join(c for c in global_status if c in "0123456789abcdefABCDEF")
    return len(digits) >= 12 and int(digits[:6], 16) & RING_FAULT_BIT != 0


class SafeStop:
    """Polls ``???`` on each controller every ``interval`` seconds on a thread."""

    def __init__(self, controllers: Dict[str, object],
                 report: Callable[[RingFaultReport], None], interval: float = 0.002) -> None:
        self.controllers = controllers
        self.report = report
        self.interval = interval
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None
        self.errors: List[str] = []

    def check_once(self) -> Optional[RingFaultReport]:
        """One pass over the controllers; the report if one has a ring fault."""
        for name, pmac in self.controllers.items():
            reply, ok = pmac.sendCommand("???")
            if not ok:
                self.errors.append(f"{name}: {reply!r}")
                continue
            if ring_fault(reply):
                stopped = []
                for other, p in self.controllers.items():
                    _, done = p.sendCommand("\x01")  # CTRL-A: abort all motion
                    if done:
                        stopped.append(other)
                return RingFaultReport(name, reply.strip("\r\x06"), stopped, time.monotonic())
        return None

    def _run(self) -> None:
        while not self._stop.is_set():
            r = self.check_once()
            if r is not None:
                self.report(r)
                return
            self._stop.wait(self.interval)

    def start(self) -> "SafeStop":
        self._thread = threading.Thread(target=self._run, name="safe-stop", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5)
