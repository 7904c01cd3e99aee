"""Host-port framing against the real card process (raw sockets; independent of the
interpreter's command coverage)."""

from conftest import ascii_reply_done, connect, getresponse, is_closed, read_until, set_host_mode, vr


def test_eth_empty_getresponse_is_ack(pmac2_card):
    with connect(pmac2_card.pmac_eth) as s:
        s.sendall(getresponse(b""))
        assert read_until(s, lambda b: len(b) >= 1) == b"\x06"


def test_eth_flush_readready_ctrl_response(pmac2_card):
    with connect(pmac2_card.pmac_eth) as s:
        s.sendall(vr(0x40, 0xB3))
        assert read_until(s, lambda b: len(b) >= 1) == b"@"
        s.sendall(vr(0xC0, 0xC2, length=2))
        assert read_until(s, lambda b: len(b) >= 2) == b"\x00\x00"
        # ^K (kill all) has no output: a lone ACK, in either byte of wValue.
        s.sendall(vr(0xC0, 0xC4, value=0x0B))
        assert read_until(s, lambda b: len(b) >= 1) == b"\x06"
        s.sendall(vr(0xC0, 0xC4, value=0x0B00))
        assert read_until(s, lambda b: len(b) >= 1) == b"\x06"


def test_eth_garbage_closes_only_that_connection(pmac2_card):
    with connect(pmac2_card.pmac_eth) as good, connect(pmac2_card.pmac_eth) as bad:
        bad.sendall(b"GET / HTTP/1.1\r\nHost: card\r\n\r\n")
        assert is_closed(bad)
        good.sendall(getresponse(b""))
        assert read_until(good, lambda b: len(b) >= 1) == b"\x06"


def test_eth_oversized_packet_closes(pmac2_card):
    with connect(pmac2_card.pmac_eth) as s:
        s.sendall(vr(0x40, 0xBF, length=4000))
        assert is_closed(s)


def test_ascii_error_framing_with_i3_2_i6_1(pmac2_card):
    set_host_mode(pmac2_card.ascii)
    with connect(pmac2_card.ascii) as s:
        s.sendall(b"UUU\r\n")
        assert read_until(s, ascii_reply_done) == b"\x07ERR003\r"


def test_ascii_overlong_line_is_err003_then_resync(pmac2_card):
    set_host_mode(pmac2_card.ascii)
    with connect(pmac2_card.ascii) as s:
        s.sendall(b"P" * 5000 + b"\r")
        assert read_until(s, ascii_reply_done) == b"\x07ERR003\r"
        s.sendall(b"UUU\r")
        assert read_until(s, ascii_reply_done) == b"\x07ERR003\r"
