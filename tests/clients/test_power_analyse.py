"""dls-powerpmacanalyse (pinned, unmodified analysis module) reads a Power card back over SSH
through dls_pmaclib's PPmacSshInterface: the system maxima, and the active elements of indexed
data structures, walked index by index until the card answers ILLEGAL (as the tool does with
the structures it finds in the controller's symbol tables). The tool's GUI module (PyQt5) is
replaced by an empty module: the analysis never uses it. Every wait is bounded."""

import sys
import types

import pytest
from dls_pmaclib.dls_pmacremote import PPmacSshInterface

# The GUI front-end dls_ppmacanalyse imports at load time (PyQt5; not installed).
sys.modules.setdefault(
    "dls_powerpmacanalyse.ppmacanalyse_control",
    types.ModuleType("dls_powerpmacanalyse.ppmacanalyse_control"),
)
from dls_powerpmacanalyse import dls_ppmacanalyse as analyse  # noqa: E402


@pytest.fixture(autouse=True)
def bounded(deadline):
    """Every test here is bounded (conftest's `deadline`)."""


@pytest.fixture
def ssh(power_card):
    client = PPmacSshInterface(timeout=5.0)
    client.setConnectionParams("127.0.0.1", power_card.ssh)
    assert client.connect() is None
    # The tool talks through its module-level client.
    analyse.sshClient = client
    yield client
    client.disconnect()


def test_system_maxima_are_read_back(ssh):
    ppmac = analyse.PowerPMAC()
    hw = analyse.PPMACHardwareWriteRead(ppmac)
    hw.readSysMaxes()
    assert ppmac.source == "hardware"
    assert ppmac.numberOfMotors == 32
    assert ppmac.numberOfCoordSystems == 16
    assert ppmac.numberOfCompTables == 0
    assert ppmac.numberOfCamTables == 0
    assert ppmac.numberOfECATs == 0
    assert ppmac.numberOfEncTables == 16


def test_active_elements_are_read_back_index_by_index(ssh):
    for cmd in ("Motor[3].JogSpeed=12.5", "Motor[31].JogSpeed=7", "P17=42"):
        reply, ok = ssh.sendCommand(cmd)
        assert ok and reply == "\r\r", (cmd, reply)
    hw = analyse.PPMACHardwareWriteRead(analyse.PowerPMAC())
    elements = hw.getActiveElementsFromDataStructures(
        ["Motor[].JogSpeed", "Sys.MaxMotors", "Gate3[].MacroEnableA"], set()
    )
    jog = {k: v[1] for k, v in elements.items() if k.startswith("Motor[")}
    # Motors 0-31 exist; Motor[32] is ILLEGAL and ends the walk.
    assert sorted(jog) == sorted(f"Motor[{i}].JogSpeed" for i in range(32))
    assert jog["Motor[3].JogSpeed"] == "12.5"
    assert jog["Motor[31].JogSpeed"] == "7"
    assert elements["Sys.MaxMotors"][1] == "32"
    gate3 = sorted(k for k in elements if k.startswith("Gate3["))
    assert gate3 == sorted(f"Gate3[{i}].MacroEnableA" for i in range(16))
    # The walk left the card as it was.
    reply, ok = ssh.sendCommand("P17")
    assert ok and reply == "42\r"


def test_buffered_programs_are_read_back(ssh):
    """The tool's program read-back: `buffer` names each buffer with its offset and size, then
    `list {name}` reads each one's text (seed L33567-33602, L36521-36754)."""
    for cmd in (
        "open prog 25",
        "linear abs",
        "X10 Y(P1)",
        "close",
        "open subprog 7",
        "return",
        "close",
        "open plc 3",
        "P10 = P10 + 1",
        "close",
    ):
        reply, ok = ssh.sendCommand(cmd)
        assert ok and reply == "\r\r", (cmd, reply)
    hw = analyse.PPMACHardwareWriteRead(analyse.PowerPMAC())
    info = hw.getBufferedProgramsInfo()
    hw.appendBufferedProgramsInfoWithListings(info)
    assert info["Motion"] == {
        "Prog25": ["Prog25", "0", "21", "Motion", ["linear abs\n", "X10 Y(P1)\n"]]
    }
    assert info["SubProg"] == {"SubProg7": ["SubProg7", "21", "7", "SubProg", ["return\n"]]}
    assert info["Plc"] == {"Plc3": ["Plc3", "28", "14", "Plc", ["P10 = P10 + 1\n"]]}
    assert info["Inverse"] == {} and info["Forward"] == {}
