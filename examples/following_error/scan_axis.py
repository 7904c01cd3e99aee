"""A scan axis mover, as host software might have one: start a move of one or more motors,
poll their status until every one is in position, and when the controller kills a motor on
a fatal following error (a jammed stage, a sticking bearing, a lost encoder), stop the rest
of the scan at once and raise with what it saw.

It talks to the controller through any object with ``sendCommand(line) -> (reply, ok)``
(dls-pmaclib's interfaces).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Dict


class FollowingErrorTrip(Exception):
    """The controller killed a motor on its fatal following-error limit (Ixx11)."""

    def __init__(self, motor: int, positions: Dict[int, float]) -> None:
        super().__init__(f"motor {motor}: fatal following error at {positions[motor]:.0f} "
                         f"counts; scan stopped at {positions}")
        self.motor = motor
        self.positions = positions


def _words(reply: str) -> "tuple[int, int]":
    digits = "".join(c for c in reply if c in "0123456789abcdefABCDEF")
    if len(digits) < 12:
        raise ValueError(f"unexpected motor status reply {reply!r}")
    return int(digits[:6], 16), int(digits[6:12], 16)


FATAL_FE = 1 << 2          # word 2 bit 2
IN_POSITION = 1 << 0       # word 2 bit 0
OPEN_LOOP = 1 << 18        # word 1 bit 18


@dataclass
class ScanAxes:
    """Moves ``motors`` together and watches them."""

    pmac: Any
    motors: tuple = (1,)
    speed: float = 16.0                      # counts/ms (Ixx22)
    targets: Dict[int, float] = field(default_factory=dict)

    def send(self, line: str) -> str:
        """One command line; the reply without its framing (CR, ACK)."""
        reply, ok = self.pmac.sendCommand(line)
        if not ok or "ERR" in reply:
            raise RuntimeError(f"{line!r}: controller replied {reply!r}")
        return reply.strip("\r\n\x06")

    def enable(self) -> None:
        """Close every motor's loop where it stands (``#nJ/``), e.g. after a trip."""
        for m in self.motors:
            self.send(f"#{m}J/")

    def start(self, targets: Dict[int, float]) -> None:
        """Start a move of each motor to its target (counts)."""
        self.targets = dict(targets)
        for m, t in targets.items():
            self.send(f"I{m}19=1 I{m}22={self.speed}")
            self.send(f"#{m}J={t}")

    def wait(self, timeout: float = 60.0) -> Dict[int, float]:
        """Wait until every motor is in position; the positions. On a fatal following error
        of any motor, kill every motor of the scan (``#nK``) and raise
        :class:`FollowingErrorTrip`."""
        deadline = time.monotonic() + timeout
        while True:
            done = True
            for m in self.motors:
                w1, w2 = _words(self.send(f"#{m}?"))
                if w2 & FATAL_FE:
                    for k in self.motors:
                        self.send(f"#{k}K")
                    pos = {k: float(self.send(f"#{k}P")) for k in self.motors}
                    raise FollowingErrorTrip(m, pos)
                if w1 & OPEN_LOOP or not w2 & IN_POSITION:
                    done = False
            if done:
                return {k: float(self.send(f"#{k}P")) for k in self.motors}
            if time.monotonic() > deadline:
                raise TimeoutError(f"scan not in position in {timeout} s")
            time.sleep(0.01)
