"""A homing routine, as host software might have one for each axis: set the home-search
speed and offset, start the search (``#nHM``), watch the motor status until the search
completes, and fail clearly when a limit switch stops the axis first.

It talks to the controller through ``send(line) -> reply`` (any PMAC connection).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable


class HomingFailed(Exception):
    """The home search did not complete."""


@dataclass
class MotorStatus:
    """The bits of ``#n?`` (two 24-bit words) this routine looks at."""

    word1: int
    word2: int

    @classmethod
    def parse(cls, reply: str) -> "MotorStatus":
        digits = "".join(c for c in reply if c in "0123456789abcdefABCDEF")
        if len(digits) < 12:
            raise HomingFailed(f"unexpected motor status reply {reply!r}")
        return cls(int(digits[:6], 16), int(digits[6:12], 16))

    @property
    def home_complete(self) -> bool:  # word 2 bit 10
        return bool(self.word2 & (1 << 10))

    @property
    def in_position(self) -> bool:  # word 2 bit 0
        return bool(self.word2 & 1)

    @property
    def positive_limit(self) -> bool:  # word 1 bit 21 (hardware +limit)
        return bool(self.word1 & (1 << 21))

    @property
    def negative_limit(self) -> bool:  # word 1 bit 22 (hardware -limit)
        return bool(self.word1 & (1 << 22))

    @property
    def open_loop(self) -> bool:  # word 1 bit 18: killed (e.g. by a ring fault)
        return bool(self.word1 & (1 << 18))

    @property
    def homing(self) -> bool:  # word 1 bit 10: home search in progress
        return bool(self.word1 & (1 << 10))


def home(send: Callable[[str], str], motor: int, speed: float = 32.0,
         offset: float = 0.0, timeout: float = 60.0) -> float:
    """Home ``motor`` at ``speed`` counts/ms (sign = direction) onto its home switch, with
    its zero ``offset`` counts from the switch edge. Returns the position after the search
    has settled; raises :class:`HomingFailed` if a limit switch or the timeout ends it."""
    send(f"I{motor}23={speed} I{motor}26={round(offset * 16)}")
    send(f"#{motor}HM")
    deadline = time.monotonic() + timeout
    while True:
        st = MotorStatus.parse(send(f"#{motor}?"))
        if st.home_complete and st.in_position:
            return float(send(f"#{motor}P"))
        if (st.positive_limit or st.negative_limit) and not st.homing:
            side = "positive" if st.positive_limit else "negative"
            raise HomingFailed(f"motor {motor}: the {side} limit switch stopped the home "
                               f"search before the home switch")
        if st.open_loop:
            raise HomingFailed(f"motor {motor} was killed during the home search "
                               f"(open loop: amplifier fault or ring fault)")
        if time.monotonic() > deadline:
            raise HomingFailed(f"motor {motor}: home search not complete in {timeout} s")
        time.sleep(0.01)
