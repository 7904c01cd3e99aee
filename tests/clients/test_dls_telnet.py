"""dls-pmaclib PmacTelnetInterface (terminal-server style, CR LF) against a real card on its
ASCII port. The client does not set I3/I6 itself, so I3=2 I6=1 is sent on a raw socket first
(they are card-global)."""

import pytest
from dls_pmaclib.dls_pmacremote import PmacTelnetInterface

from conftest import ascii_reply_done, connect, read_until, set_host_mode


@pytest.fixture(scope="module")
def tn(pmac2_card):
    set_host_mode(pmac2_card.ascii)
    pmac = PmacTelnetInterface(timeout=5.0)
    pmac.setConnectionParams("127.0.0.1", pmac2_card.ascii)
    err = pmac.connect()
    assert err is None, err
    yield pmac
    pmac.disconnect()


def send(pmac, cmd):
    reply, ok = pmac.sendCommand(cmd)
    assert ok, reply
    return reply


def test_version_is_ack_terminated(tn):
    reply = send(tn, "ver")
    assert reply.endswith("\r\x06") and len(reply) > 2


def test_variables_and_ranges(tn):
    assert send(tn, "P1=25 P2=50 P3=75") == "\x06"
    assert send(tn, "P1") == "25\r\x06"
    assert send(tn, "P1..3") == "25\r50\r75\r\x06"
    assert send(tn, "P1023=-0.333333333 P1023") == "-0.333333333\r\x06"


def test_errors(tn):
    assert send(tn, "UUU") == "\x07ERR003\r"
    # PMAC2 has 8 motors: #9 is out of range.
    assert send(tn, "#9") == "\x07ERR003\r"


def test_send_series_program_and_list(tn):
    program = ["CLOSE", "OPEN PLC 5 CLEAR", "P100=P100+1", "CLOSE"]
    results = list(tn.sendSeries(list(enumerate(program, 1))))
    assert all(ok for ok, _, _, _ in results), results
    assert send(tn, "LIST PLC 5") == "P100=P100+1\rRET\r\x06"


def test_another_hosts_ctrl_t_does_not_echo_this_hosts_lines(pmac2_card):
    """Issue 26 item 2: after a second host sent CTRL-T (full duplex), every poll of this
    client read its own line echoed before the reply ('P5\\r55\\r\\x06', still ok=True)."""
    set_host_mode(pmac2_card.ascii)
    pmac = PmacTelnetInterface(timeout=5.0)
    pmac.setConnectionParams("127.0.0.1", pmac2_card.ascii)
    assert pmac.connect() is None
    try:
        assert send(pmac, "P5=55") == "\x06"
        with connect(pmac2_card.ascii) as other:
            other.sendall(b"\x14P6\r")
            assert read_until(other, ascii_reply_done).endswith(b"0\r\x06")
            other.sendall(b"P6\r")
            # That host is in full duplex: its own line comes back before the reply.
            assert read_until(other, ascii_reply_done) == b"P6\r0\r\x06"
            for _ in range(20):
                assert pmac.sendCommand("P5") == ("55\r\x06", True)
    finally:
        pmac.disconnect()
