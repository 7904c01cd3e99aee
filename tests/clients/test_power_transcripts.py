"""The Power PMAC seed's own on-line command examples (tests/transcripts/power/*.txt, each case
citing its seed lines) against a fresh standalone Power card, once through its raw gpascii
port and once through dls_pmaclib's PPmacSshInterface, unmodified: the same lines give the
same reply lines on both. Every wait is bounded."""

import socket
import time
from pathlib import Path

import pytest
from dls_pmaclib.dls_pmacremote import PPmacSshInterface
from conftest import CardProcess

TRANSCRIPTS = sorted((Path(__file__).resolve().parents[1] / "transcripts" / "power").glob("*.txt"))


def parse(path):
    """[(title, [(line, [reply lines])])] of a transcript file."""
    cases = []
    for n, raw in enumerate(path.read_text().splitlines(), 1):
        line = raw.rstrip("\n")
        if not line.strip() or line.startswith("#"):
            continue
        if line.startswith("== "):
            cases.append((line[3:], []))
        elif line.startswith("> "):
            assert cases, f"{path.name}:{n}: a line before the first case"
            cases[-1][1].append((line[2:], []))
        elif line.startswith("< "):
            assert cases and cases[-1][1], f"{path.name}:{n}: a reply before any line"
            cases[-1][1][-1][1].append(line[2:])
        else:
            raise AssertionError(f"{path.name}:{n}: not a transcript line: {line!r}")
    return cases


class Gpascii:
    """The raw gpascii port: a line out, its reply lines (CR LF) up to the ACK line back."""

    def __init__(self, port):
        self.s = socket.create_connection(("127.0.0.1", port), timeout=5.0)
        self.buf = b""
        # The banner ends in LF alone (as gpascii writes it); reply lines in CR LF.
        banner = self._line(b"\n")
        assert banner == b"STDIN Open for ASCII Input", banner

    def _line(self, end=b"\r\n"):
        while end not in self.buf:
            chunk = self.s.recv(4096)
            assert chunk, "connection closed"
            self.buf += chunk
        line, self.buf = self.buf.split(end, 1)
        return line

    def send(self, text):
        self.s.sendall(text.encode() + b"\n")
        out = []
        while True:
            line = self._line()
            if line == b"\x06":
                return out
            out.append(line.decode())

    def close(self):
        self.s.close()


class Ssh:
    """dls_pmaclib's PPmacSshInterface (`gpascii -2` in an SSH shell), as host tools use it."""

    def __init__(self, port):
        self.p = PPmacSshInterface(timeout=5.0)
        self.p.setConnectionParams("127.0.0.1", port)
        err = self.p.connect()
        assert err is None, err

    def send(self, text):
        reply, ok = self.p.sendCommand(text)
        assert ok, (text, reply)
        # The client joins reply lines with CR (and ends with one); a line answered by its
        # ACK alone comes back as empty lines.
        return [l for l in reply.split("\r") if l]

    def close(self):
        self.p.disconnect()


@pytest.fixture(autouse=True)
def bounded(deadline):
    """Every test here is bounded (conftest's `deadline`)."""


@pytest.mark.parametrize("transport", ["gpascii", "ssh"])
@pytest.mark.parametrize("path", TRANSCRIPTS, ids=[p.stem for p in TRANSCRIPTS])
def test_seed_examples(path, transport):
    cases = parse(path)
    assert len(cases) >= 15, f"{path.name}: {len(cases)} cases"
    card = CardProcess("power")
    try:
        link = Gpascii(card.gpascii) if transport == "gpascii" else Ssh(card.ssh)
        try:
            failures = []
            for title, lines in cases:
                for text, want in lines:
                    got = link.send(text)
                    if got != want:
                        failures.append(f"[{title}] {text!r}: got {got!r}, want {want!r}")
            assert not failures, "\n".join(failures)
        finally:
            link.close()
    finally:
        card.stop()


def test_the_transcripts_parse_and_cite_the_seed():
    for path in TRANSCRIPTS:
        for title, lines in parse(path):
            assert title.startswith("L"), f"{path.name}: case without a seed line: {title}"
            assert lines, f"{path.name}: empty case {title}"
