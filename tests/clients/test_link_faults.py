"""Host-link faults (issue 23 item 4) seen through the host libraries users test with:
dls-pmaclib's PmacTelnetInterface (ASCII port) and PmacEthernetInterface (PMAC Ethernet port)
against `mcc fault card0 link KIND`, pytrinamic's SocketTmclInterface against `mcc fault bus
link KIND`, raw chain bytes against `mcc fault chain link KIND`. Each kind's faulted bytes are
fixed by its seed (`mcc_ring::linkfault`); each assertion is what the library raises or
returns. Every fault is given for one reply (`--cycles 1`) and the next call must work."""

import socket
import time

import pytest
from dls_pmaclib.dls_pmacremote import PmacEthernetInterface, PmacTelnetInterface
from pytrinamic.connections import SocketTmclInterface
from pytrinamic.tmcl import TMCLReplyChecksumError

from conftest import set_host_mode
from emcl_cluster import EmclCluster

TIMEOUT = 20  # seconds a reply may take on a busy machine
SHORT = 2.0  # seconds a client waits for a reply the fault drops


@pytest.fixture(scope="module")
def cluster():
    c = EmclCluster()
    doc = c.status()
    c.card = doc["cards"][0]
    set_host_mode(c.card["ascii"])
    yield c
    c.stop()


def fault(cluster, target, kind, *options):
    return cluster.mcc("fault", target, "link", kind, "--cycles", "1", *options)


@pytest.fixture
def telnet(cluster):
    pmac = PmacTelnetInterface(timeout=TIMEOUT)
    pmac.setConnectionParams("127.0.0.1", cluster.card["ascii"])
    assert pmac.connect() is None
    assert pmac.sendCommand("P1=25") == ("\x06", True)
    yield pmac
    pmac.disconnect()


@pytest.fixture
def ethernet(cluster):
    pmac = PmacEthernetInterface(timeout=TIMEOUT)
    pmac.setConnectionParams("127.0.0.1", cluster.card["pmac_eth"])
    assert pmac.connect() is None
    assert pmac.sendCommand("P1=25") == ("\x06", True)
    yield pmac
    pmac.disconnect()


@pytest.fixture
def trinamic(cluster):
    iface = SocketTmclInterface(cluster.tcp, timeout_s=TIMEOUT)
    iface._socket.settimeout(TIMEOUT)  # pytrinamic sets none (it would block on silence)
    assert iface.get_version_string() == "1360V131"
    yield iface
    iface.close()


# ------------------------------------------------------------------ PmacTelnetInterface


def test_telnet_no_reply_times_out_then_the_next_command_works(cluster, telnet):
    fault(cluster, "card0", "no-reply")
    telnet.timeout = SHORT
    reply, ok = telnet.sendCommand("P1")
    assert not ok and "Timed out waiting for expected response" in reply, reply
    telnet.timeout = TIMEOUT
    assert telnet.sendCommand("P1") == ("25\r\x06", True)


def test_telnet_stray_bel_reaches_the_caller_as_part_of_a_good_reply(cluster, telnet):
    # Seed 7 puts the BEL before the CR: the client takes the reply as it is.
    fault(cluster, "card0", "stray-bel", "--seed", "7")
    assert telnet.sendCommand("P1") == ("25\x07\r\x06", True)
    assert telnet.sendCommand("P1") == ("25\r\x06", True)


def test_telnet_short_reply_times_out_with_what_came(cluster, telnet):
    # Seed 0 keeps "25\r" of "25\r<ACK>": no terminator, the client times out on it.
    fault(cluster, "card0", "short", "--seed", "0")
    telnet.timeout = SHORT
    reply, ok = telnet.sendCommand("P1")
    assert not ok and 'Got only: "25\r"' in reply, repr(reply)
    telnet.timeout = TIMEOUT
    assert telnet.sendCommand("P1") == ("25\r\x06", True)


def test_telnet_late_reply_arrives_whole_after_the_delay(cluster, telnet):
    fault(cluster, "card0", "late", "--delay", "400")
    t = time.monotonic()
    assert telnet.sendCommand("P1") == ("25\r\x06", True)
    assert time.monotonic() - t >= 0.4


def test_telnet_reset_breaks_the_connection(cluster, telnet):
    fault(cluster, "card0", "reset")
    reply, ok = telnet.sendCommand("P1")
    assert not ok and "Communication with PMAC broken" in reply, reply
    again = PmacTelnetInterface(timeout=TIMEOUT)
    again.setConnectionParams("127.0.0.1", cluster.card["ascii"])
    assert again.connect() is None
    assert again.sendCommand("P1") == ("25\r\x06", True)
    again.disconnect()


# ---------------------------------------------------------------- PmacEthernetInterface


def test_ethernet_no_reply_is_a_socket_error(cluster, ethernet):
    fault(cluster, "card0", "no-reply")
    ethernet.timeout = SHORT
    reply, ok = ethernet.sendCommand("P1")
    assert not ok and "Socket communication error" in reply, reply
    ethernet.timeout = TIMEOUT
    assert ethernet.sendCommand("P1") == ("25\r\x06", True)


def unexpected_terminator(ethernet):
    """sendCommand says only "Socket communication error": its cause names the terminator."""
    with pytest.raises(OSError, match="Socket communication error") as e:
        ethernet._sendCommand("P1")
    assert "unexpected terminator" in str(e.value.__cause__), e.value.__cause__


def test_ethernet_corrupted_ack_is_an_unexpected_terminator(cluster, ethernet):
    # Seed 0 flips bit 5 of the ACK: "25\r<ACK>" ends in "&".
    fault(cluster, "card0", "corrupt", "--seed", "0")
    unexpected_terminator(ethernet)
    assert ethernet.sendCommand("P1") == ("25\r\x06", True)


def test_ethernet_stray_escape_after_the_ack_is_an_unexpected_terminator(cluster, ethernet):
    # Seed 1 appends an ESC after the ACK.
    fault(cluster, "card0", "stray-ctrl", "--seed", "1")
    unexpected_terminator(ethernet)
    assert ethernet.sendCommand("P1") == ("25\r\x06", True)


def test_ethernet_takes_a_reply_cut_after_its_cr_for_a_good_one(cluster, ethernet):
    # Seed 0 keeps "25\r": the client passes a CR-terminated short reply up as a success
    # (its "error responses pass up" case): the truncation goes unnoticed.
    fault(cluster, "card0", "short", "--seed", "0")
    assert ethernet.sendCommand("P1") == ("25\r", True)
    assert ethernet.sendCommand("P1") == ("25\r\x06", True)


def test_ethernet_reset_is_a_socket_error(cluster, ethernet):
    fault(cluster, "card0", "reset")
    reply, ok = ethernet.sendCommand("P1")
    assert not ok and "Socket communication error" in reply, reply


# ------------------------------------------------------------ pytrinamic on the EMCL bus


def test_pytrinamic_bad_checksum_raises_its_checksum_error(cluster, trinamic):
    fault(cluster, "bus", "bad-checksum")
    with pytest.raises(TMCLReplyChecksumError):
        trinamic.get_axis_parameter(6, 0)
    assert trinamic.get_version_string() == "1360V131"


def test_pytrinamic_no_reply_times_out(cluster, trinamic):
    fault(cluster, "bus", "no-reply")
    trinamic._socket.settimeout(SHORT)
    with pytest.raises((socket.timeout, TimeoutError)):
        trinamic.get_version_string()
    trinamic._socket.settimeout(TIMEOUT)
    assert trinamic.get_version_string() == "1360V131"


def test_pytrinamic_reset_raises_a_connection_error(cluster, trinamic):
    fault(cluster, "bus", "reset")
    with pytest.raises((ConnectionError, OSError)):
        trinamic.get_version_string()


# ----------------------------------------------------------------- chain, status, refusals


def chain_ask(cluster, line, n, timeout=TIMEOUT):
    host, port = cluster.status()["daisy_chain"].rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=timeout) as s:
        s.sendall(line)
        got = b""
        while len(got) < n:
            chunk = s.recv(4096)
            if not chunk:
                break
            got += chunk
        return got


def test_chain_replies_are_faulted_and_the_card_state_is_not(cluster):
    clean = chain_ask(cluster, b"P1\r", 4)
    assert clean == b"25\r\x06", clean
    fault(cluster, "chain", "stray-lf", "--seed", "7")
    assert chain_ask(cluster, b"P1\r", 5) == b"25\n\r\x06"
    assert chain_ask(cluster, b"P1\r", 4) == clean


def test_status_shows_every_link_fault_and_clear_removes_them(cluster):
    cluster.mcc("fault", "card0", "link", "corrupt", "--probability", "0")
    cluster.mcc("fault", "chain", "link", "late", "--delay", "5", "--probability", "0")
    cluster.mcc("fault", "bus", "link", "short", "--probability", "0", "--seed", "9")
    doc = cluster.status()
    assert doc["cards"][0]["link_fault"]["kind"] == "corrupt"
    assert doc["link_faults"]["chain"]["delay_ms"] == 5
    assert doc["link_faults"]["bus"]["seed"] == 9
    cluster.mcc("fault", "clear")
    doc = cluster.status()
    assert doc["cards"][0]["link_fault"] is None
    assert doc["link_faults"] == {"chain": None, "bus": None}


def test_refusals_name_the_reason_and_the_choices(cluster):
    with pytest.raises(RuntimeError) as e:
        cluster.mcc("fault", "card0", "link", "bad-checksum")
    assert "EMCL bus only" in str(e.value)
    with pytest.raises(RuntimeError) as e:
        cluster.mcc("fault", "bus", "link", "melt")
    assert "no-reply, late, short" in str(e.value)
    with pytest.raises(RuntimeError) as e:
        cluster.mcc("fault", "station0", "link", "short")
    assert "card0" in str(e.value) and "chain, bus" in str(e.value)
