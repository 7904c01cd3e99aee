"""A two-axis synchronized scan, as host software would run it: each controller gets the
same motion program, and the scan starts with one line on the daisy chain (the serial
multi-drop line: ``@n`` addresses controller n) so both programs start together.

It talks to the daisy chain over TCP, as through a terminal server on the serial port.
"""

from __future__ import annotations

import socket
from typing import List, Sequence, Tuple

PROGRAM = 10


class DaisyChain:
    """A serial daisy chain reached through a terminal server (raw TCP)."""

    def __init__(self, address: Tuple[str, int], timeout: float = 5.0) -> None:
        self.sock = socket.create_connection(address, timeout=timeout)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.timeout = timeout

    def command(self, line: str, quiet: float = 0.1) -> str:
        """Send a line; the reply (whatever arrives until the line has been quiet for
        ``quiet`` seconds). A BELL (error) raises."""
        self.sock.sendall(line.encode() + b"\r")
        data = b""
        self.sock.settimeout(quiet)
        while True:
            try:
                chunk = self.sock.recv(4096)
            except socket.timeout:
                break
            if not chunk:
                break
            data += chunk
        if b"\x07" in data:
            raise RuntimeError(f"{line!r} refused: {data!r}")
        return data.decode(errors="replace")

    def close(self) -> None:
        self.sock.close()


def program_lines(distance: float, feed: float) -> List[str]:
    """The scan program: one linear move of ``distance`` units at ``feed`` units/s."""
    return [f"OPEN PROG {PROGRAM} CLEAR", f"LINEAR INC TA50 TS0 F{feed}", f"X{distance}",
            "CLOSE"]


def load(chain: DaisyChain, cards: Sequence[int], distance: float, feed: float) -> None:
    """Motor 1 of each card is axis X of coordinate system 1 (loop closed), with the scan
    program."""
    for n in cards:
        chain.command(f"@{n:X}")
        for line in ["&1#1->1000X", "#1J/", *program_lines(distance, feed)]:
            chain.command(line)


def start(chain: DaisyChain, cards: Sequence[int]) -> None:
    """Start the scan on every card with one line: ``@0&1B10R@1&1B10R``."""
    chain.command("".join(f"@{n:X}&1B{PROGRAM}R" for n in cards))
