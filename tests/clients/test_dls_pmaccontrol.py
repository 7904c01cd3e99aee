"""dls-pmaccontrol (Diamond's PMAC GUI, from PyPI, unmodified) headless against a Turbo card on
a MACRO ring, started with no axis count on its command line: its own window class connects
over PMAC Ethernet, counts the axes from I20-I23 (8 per MACRO IC), polls the card through its
comms thread, shows motor 1's `?` word on its status screen ("Amplifier enabled" lit for an
enabled motor, dark for a killed one) and reads the station's MI910/MI912/MI913/MI916 on the
"PID and macro" tab of its axis settings without an error box. Qt runs offscreen."""

import os
import time
import types

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import pytest  # noqa: E402
from dls_pmaclib.dls_pmacremote import PmacEthernetInterface  # noqa: E402
from PyQt5.QtWidgets import QApplication, QMessageBox  # noqa: E402

from mcc_cluster import turbo_cluster  # noqa: E402

#: Upper bound for the GUI's poll loop to show a change (ring time may be slow on a busy host).
POLL_TIMEOUT = 60.0


@pytest.fixture(scope="module")
def port(tmp_path_factory):
    """The PMAC Ethernet port of a Turbo card on a ring with one station."""
    ring = turbo_cluster("pmaccontrol", tmp_path_factory.mktemp("cfg"), 1)
    try:
        yield ring.status()["cards"][0]["pmac_eth"]
    finally:
        ring.stop()


@pytest.fixture(scope="module")
def host(port):
    """A second host connection (as an operator's terminal) to set the card up."""
    p = PmacEthernetInterface(timeout=10.0)
    p.setConnectionParams("127.0.0.1", port)
    assert p.connect() is None
    yield p
    p.disconnect()


def send(p, cmd):
    reply, ok = p.sendCommand(cmd)
    assert ok and "ERR" not in reply, (cmd, reply)
    return reply.split("\r")[0]


@pytest.fixture(scope="module")
def app():
    return QApplication.instance() or QApplication(["pmaccontrol"])


@pytest.fixture
def errors(monkeypatch):
    """Every message box the GUI would pop up (the test has no one to click them)."""
    seen = []
    monkeypatch.setattr(QMessageBox, "information",
                        staticmethod(lambda parent, title, text, *a: seen.append((title, text))))
    return seen


@pytest.fixture
def window(app, port, errors):
    from dls_pmac_control.__main__ import Controlform

    options = types.SimpleNamespace(server="127.0.0.1", port=str(port), defaultAxis=1,
                                    nAxes=None, macroAxisStartIndex=0, username="root",
                                    password="unused", verbose=False, protocol="tcpip",
                                    timeout=10.0)
    w = Controlform(options)
    yield w
    w.die()
    w.commsThread.updateThreadHandle.join(timeout=30)


def pump_until(app, what, f, timeout=POLL_TIMEOUT):
    deadline = time.monotonic() + timeout
    while True:
        app.processEvents()
        v = f()
        if v:
            return v
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)


def led_on(w, label):
    """Whether the status screen's LED next to `label` shows the green 'on' pixmap."""
    i = w.statusScreen.lstLabelTexts.index(label)
    return w.statusScreen.lstLeds[i].pixmap().cacheKey() == w.greenLedOn.cacheKey()


def test_axes_amplifier_and_macro_tab(app, window, host, errors):
    w = window
    w.remoteConnect()
    assert errors == []
    assert w.windowTitle() == "Delta Tau motor controller - Turbo PMAC2-VME"
    # no -n on the command line: the axis count comes from I20-I23 (one MACRO IC, 8 axes)
    assert send(host, "I20") == "$78400"
    assert w.pmac.getNumberOfAxes() == 8
    assert w.table.rowCount() == 8

    # an enabled motor (closed loop at rest) lights "Amplifier enabled"; a killed one does not
    send(host, "#1K")
    send(host, "#1J/")
    pump_until(app, "motor 1 amplifier enabled", lambda: led_on(w, "Amplifier enabled"))
    assert led_on(w, "Motor activated")
    assert w.table.item(0, 0).text() != ""
    send(host, "#1K")
    pump_until(app, "motor 1 killed", lambda: not led_on(w, "Amplifier enabled"))
    assert led_on(w, "Motor activated")
    send(host, "#1J/")

    # the "PID and macro" tab reads the station's MI910/MI912/MI913/MI916 for motor 1 (node 0)
    send(host, "MS0,MI913=2")
    expect = [send(host, f"MS0,MI{v}") for v in (910, 912, 913, 916)]
    assert expect[2] == "2"
    w.jogParameters()
    w.axisSettingsScreen.tabAxisSetup.setCurrentIndex(1)
    w.axisSettingsScreen.axisUpdate()
    app.processEvents()
    assert errors == []
    s = w.axisSettingsScreen
    shown = [s.lneLoopSelect.text(), s.lneCaptureOn.text(), s.lneCaptureFlag.text(),
             s.lneOutputMode.text()]
    assert shown == expect
    assert s.lneIx30.text() == send(host, "I130")
    send(host, "MS0,MI913=0")
