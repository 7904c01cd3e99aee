"""dls-pmaclib PmacEthernetInterface against a real card (Turbo host-compat profile, which the
DLS clients assume: CID 602413, variables 0..8191)."""

import re

import pytest
from dls_pmaclib.dls_pmacremote import PmacEthernetInterface


@pytest.fixture(scope="module")
def eth(turbo_card):
    pmac = PmacEthernetInterface(timeout=5.0)
    pmac.setConnectionParams("127.0.0.1", turbo_card.pmac_eth)
    err = pmac.connect()
    assert err is None, err
    yield pmac
    pmac.disconnect()


def send(pmac, cmd):
    reply, ok = pmac.sendCommand(cmd)
    assert ok, reply
    return reply


def test_connect_and_version(eth):
    # connect() itself sent "i6=1 i3=2 ver" and checked the reply; check it again explicitly.
    assert re.match(r"^\d+\.\d+\s*\r\x06$", send(eth, "ver"))


def test_model(eth):
    assert eth.getPmacModelCode() == 602413
    assert eth.getPmacModel() == "Turbo PMAC2-VME"
    assert eth.getShortModelName() == "Pmac"


def test_variable_write_read_and_ranges(eth):
    assert send(eth, "P1=25 P2=50 P3=-0.5") == "\x06"
    assert send(eth, "P1") == "25\r\x06"
    assert send(eth, "p1..3") == "25\r50\r-0.5\r\x06"
    eth.setVar("P10", 17.5)
    assert send(eth, "P10") == "17.5\r\x06"
    assert send(eth, "P20..22=3") == "\x06"
    assert send(eth, "P20..22") == "3\r3\r3\r\x06"
    assert send(eth, "P1=P1*2+1 P1") == "51\r\x06"
    # (Not "&1Q7=2.25 &1Q7": spaces mean nothing, so "2.25 &1" is the expression 2.25&1 = 0.)
    assert send(eth, "&2Q7=2.25") == "\x06"
    assert send(eth, "&2Q7") == "2.25\r\x06"
    assert send(eth, "&1Q7") == "0\r\x06"
    assert send(eth, "P8191=8191 P8191") == "8191\r\x06"


def test_errors(eth):
    assert send(eth, "UUU") == "\x07ERR003\r"
    # Commands before the failing one stay executed; the rest of the line is dropped (spec 2.8).
    assert send(eth, "P30=1 UUU P30=2") == "\x07ERR003\r"
    assert send(eth, "P30") == "1\r\x06"
    results = list(eth.sendSeries([(1, "P31=1"), (2, "UUU"), (3, "P31")]))
    assert [r[0] for r in results] == [True, False, True]
    assert results[2][3] == "1\r\x06"


def test_reply_over_20kb_through_getbuffer(eth):
    assert send(eth, "P0..8191=1.23456789") == "\x06"
    reply = send(eth, "P0..8191")
    assert len(reply) == 8192 * len("1.23456789\r") + 1 > 20_000
    assert "WARNING" not in reply
    lines = reply[:-1].split("\r")
    assert lines[-1] == "" and len(lines) == 8193
    assert set(lines[:-1]) == {"1.23456789"}


def test_control_k_as_one_byte_command(eth):
    assert send(eth, "\x0b") == "\x06"


def test_program_download_with_send_series_and_list(eth):
    program = [
        "CLOSE",
        "OPEN PROG 10 CLEAR",
        "LINEAR",
        "X1000",
        "P1=P1+1",
        "DWELL100",
        "CLOSE",
    ]
    results = list(eth.sendSeries(list(enumerate(program, 1))))
    assert all(ok for ok, _, _, _ in results), results
    assert [r[3] for r in results] == ["\x06"] * len(program)
    # I9=2: short keywords; CLOSE appended RETURN.
    assert send(eth, "LIST PROG 10") == "LIN\rX1000\rP1=P1+1\rDWE100\rRET\r\x06"
