"""SAVE through a host port survives a restart of the card process (--state-file)."""

from dls_pmaclib.dls_pmacremote import PmacEthernetInterface

from conftest import CardProcess


def session(card):
    pmac = PmacEthernetInterface(timeout=5.0)
    pmac.setConnectionParams("127.0.0.1", card.pmac_eth)
    assert pmac.connect() is None
    return pmac


def test_save_then_restart_keeps_ivars_and_programs(tmp_path):
    state = str(tmp_path / "card0.state")
    card = CardProcess("pmac2", "--state-file", state)
    try:
        pmac = session(card)
        for cmd in ["I130=1234", "OPEN PROG 3 CLEAR", "DWELL250", "CLOSE"]:
            assert pmac.sendCommand(cmd) == ("\x06", True)
        assert pmac.sendCommand("SAVE") == ("\x06", True)
        assert pmac.sendCommand("I130=1") == ("\x06", True)
        pmac.disconnect()
    finally:
        card.stop()
    card = CardProcess("pmac2", "--state-file", state)
    try:
        pmac = session(card)
        assert pmac.sendCommand("I130") == ("1234\r\x06", True)
        assert pmac.sendCommand("LIST PROG 3") == ("DWE250\rRET\r\x06", True)
        pmac.disconnect()
    finally:
        card.stop()
