"""Fixtures: a real `mcc-card --standalone` process per test module, and raw-socket helpers."""

import json
import os
import select
import signal
import socket
import struct
import subprocess
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CARD_BIN = os.environ.get("MCC_CARD_BIN", str(ROOT / "target" / "debug" / "mcc-card"))
WAIT = 5.0


class CardProcess:
    """A running card: its ASCII and PMAC-Ethernet ports on 127.0.0.1."""

    def __init__(self, profile, *extra):
        self.proc = subprocess.Popen(
            [CARD_BIN, "--standalone", "--profile", profile, "--exit-on-stdin-eof", *extra],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
        )
        ready, _, _ = select.select([self.proc.stdout], [], [], 20.0)
        if not ready:
            self.stop()
            raise RuntimeError("mcc-card did not report its ports")
        self.ports = json.loads(self.proc.stdout.readline())
        # A Power card has the gpascii and SSH ports instead of the ASCII and Ethernet ones.
        self.ascii = self.ports.get("ascii")
        self.pmac_eth = self.ports.get("pmac_eth")
        self.gpascii = self.ports.get("gpascii")
        self.ssh = self.ports.get("ssh")

    def stop(self):
        try:
            self.proc.stdin.close()
            self.proc.wait(timeout=WAIT)
        except Exception:
            self.proc.kill()
            self.proc.wait()


@pytest.fixture(scope="module")
def power_card():
    card = CardProcess("power")
    yield card
    card.stop()


# dls_pmaclib's PPmacSshInterface waits forever for a reply's end: tests using it are bounded.
POWER_TEST_TIMEOUT = 300


@pytest.fixture
def deadline():
    def expired(signum, frame):
        raise TimeoutError("no answer in time")

    old = signal.signal(signal.SIGALRM, expired)
    signal.alarm(POWER_TEST_TIMEOUT)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


@pytest.fixture(scope="module")
def pmac2_card():
    card = CardProcess("pmac2")
    yield card
    card.stop()


@pytest.fixture(scope="module")
def turbo_card():
    card = CardProcess("turbo")
    yield card
    card.stop()


def vr(request_type, request, value=0, data=b"", length=None):
    """One PMAC Ethernet request packet (big-endian 16-bit fields)."""
    if length is None:
        length = len(data)
    return struct.pack(">BBHHH", request_type, request, value, 0, length) + data


def getresponse(cmd: bytes) -> bytes:
    return vr(0x40, 0xBF, data=cmd)


def connect(port):
    s = socket.create_connection(("127.0.0.1", port), timeout=WAIT)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


def read_until(s, predicate, limit=1 << 20):
    """Read until predicate(buffer) holds (or the peer closes / the timeout hits)."""
    buf = b""
    deadline = time.monotonic() + WAIT
    while not predicate(buf) and len(buf) < limit:
        s.settimeout(max(0.01, deadline - time.monotonic()))
        chunk = s.recv(65536)
        if not chunk:
            break
        buf += chunk
    return buf


def ascii_reply_done(buf: bytes) -> bool:
    """I3=2 reply complete: ends in ACK, or a BELL error ended by CR."""
    return buf.endswith(b"\x06") or (b"\x07" in buf and buf.endswith(b"\r"))


def set_host_mode(port):
    """I3=2 I6=1 (ACK handshake, BELL+ERRnnn errors), as the DLS telnet client needs."""
    with connect(port) as s:
        s.sendall(b"I3=2 I6=1\r")
        return read_until(s, ascii_reply_done)


def is_closed(s) -> bool:
    s.settimeout(WAIT)
    try:
        while True:
            if not s.recv(4096):
                return True
    except (ConnectionResetError, BrokenPipeError):
        return True
    except socket.timeout:
        return False
