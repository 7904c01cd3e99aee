"""pmac-motorhome (Diamond's homing-PLC generator, from PyPI) against a Turbo PMAC2 on a MACRO
ring: the PLC it generates for a "PMAC" controller with MACRO axes is preprocessed and
downloaded with dls-pmaclib (ClsPmacParser + PmacEthernetInterface.sendSeries, as the DLS
download tools do), started through the generator's own group variable and watched through
its own state and status variables. The station plant places the switches, each with the
plant's default 100 counts of hysteresis (`switch_hysteresis`, spelled out below: a switch
operates at its position and releases 100 counts further out, as a real switch's
differential travel):

| motor | node | sequence        | plant                                    | zero at                  |
|-------|------|-----------------|------------------------------------------|--------------------------|
| 1     | 0    | home_hsw        | home switch 5000..6000, limits ±30000    | 5000 (rising)            |
| 2     | 1    | home_limit      | −limit −30000, Ixx23 < 0, MI913 = 2      | −30000 (operate)         |
| 3     | 4    | home_rlim       | −limit −30000, Ixx23 > 0, MI912 = 10     | −29900 (release: +100)   |
| 4     | 5    | home_hsw_hstop  | no limits, end stop at −30000, home 5000 | 5000 (rising)            |
| 5     | 8    | home_home (HM)  | home switch 5000..6000                   | 5000 (rising)            |

home_limit's retrace returns to the −limit's release count and undershoots it by some 20
counts (the fast jog ramps below): the hysteresis keeps the released switch off there, so
the limit stop does not fire and the HM (limits off) finds the switch edge itself.

The zero is checked against the plant: the MACRO node's feedback register 0 (the encoder
count the station reports, 5 fractional bits) minus the motor's reported position is where
the motor's zero lies in plant counts; it must be within 1 count of the switch edge.
"""

import time

import pytest
from dls_pmaclib.dls_pmacremote import PmacEthernetInterface
from dls_pmaclib.dls_pmcpreprocessor import ClsPmacParser
from pmac_motorhome.commands import group, motor, plc
from pmac_motorhome.sequences import (
    home_home,
    home_hsw,
    home_hsw_hstop,
    home_limit,
    home_rlim,
)

from mcc_cluster import turbo_cluster

PLC = 11
#: Switch hysteresis, counts (the station's default).
HYSTERESIS = 100
#: (group, motor, node, sequence, switch edge in plant counts)
CASES = [
    (2, 1, 0, home_hsw, 5000),
    (3, 2, 1, home_limit, -30000),
    (4, 3, 4, home_rlim, -30000 + HYSTERESIS),
    (5, 4, 5, home_hsw_hstop, 5000),
    (6, 5, 8, home_home, 5000),
]
#: One homing sequence runs a few seconds of ring time; a generous bound for a loaded machine.
HOME_TIMEOUT = 120

PLANT = f"""
[stations.plant]
plus_limit = 30000
minus_limit = -30000
switch_hysteresis = {HYSTERESIS}
[stations.plant.nodes.5]
limits = false
hard_stops = true
minus_stop = -30000
plus_stop = 30000
"""


def suggested_mvars(x):
    """The Turbo suggested M-variables the generated PLC uses for motor x (status words
    Y:$0000C0 / X:$0000B0, actual position D:$00008B, jog register L:$0000D7)."""
    b = 0x80 * (x - 1)
    y2 = 0xC0 + b
    return (f"M{x}30->Y:${y2:06X},11,1 M{x}40->Y:${y2:06X},0,1 M{x}42->Y:${y2:06X},2,1 "
            f"M{x}45->Y:${y2:06X},10,1 M{x}62->D:${0x8B + b:06X} M{x}72->L:${0xD7 + b:06X}")


@pytest.fixture(scope="module")
def ring(tmp_path_factory):
    c = turbo_cluster("motorhome", tmp_path_factory.mktemp("cfg"), 1, PLANT)
    yield c
    c.stop()


@pytest.fixture(scope="module")
def pmac(ring, tmp_path_factory):
    """The card over PMAC Ethernet, set up and with the homing PLC downloaded."""
    p = PmacEthernetInterface(timeout=10.0)
    p.setConnectionParams("127.0.0.1", ring.status()["cards"][0]["pmac_eth"])
    assert p.connect() is None
    send(p, "I5=3")
    for _, x, node, seq, _ in CASES:
        send(p, suggested_mvars(x))
        send(p, f"I{x}19=2 I{x}20=20 I{x}21=0 I{x}22=40 "
                f"I{x}23={-20 if seq is home_limit else 20} I{x}26=0")
    # home_limit homes on the -limit (MI913 = 2), home_rlim on its release (MI912 = 10,
    # MI913 = 2); the others on the home switch, rising edge (the station defaults).
    send(p, "MS1,MI913=2 MS4,MI913=2 MS4,MI912=10")
    # Ixx11 generous: the hard-stop search pushes into the end stop until the warning
    # following error (Ixx12, the FE trigger of Ixx97 = 3) fires.
    send(p, "I411=320000 I412=16000")
    for _, x, _, _, _ in CASES:
        send(p, f"#{x}J/")
    out = tmp_path_factory.mktemp("plc") / f"PLC{PLC}_homing.pmc"
    with plc(plc_num=PLC, controller="PMAC", filepath=str(out)):
        for g, x, _, seq, _ in CASES:
            with group(group_num=g):
                motor(axis=x)
                seq()
    lines = ClsPmacParser().parse(str(out))
    assert lines and any(f"OPEN PLC{PLC}" in ln for ln in lines), lines
    cmds = [(n + 1, ln) for n, ln in enumerate(lines) if ln.strip()]
    failed = [(n, c, r) for ok, n, c, r in p.sendSeries(cmds) if not ok]
    assert not failed, failed[:5]
    yield p
    p.disconnect()


def send(p, cmd):
    reply, ok = p.sendCommand(cmd)
    assert ok and "ERR" not in reply, (cmd, reply)
    return reply


def token(p, cmd):
    """The first value of the reply (without CR and ACK)."""
    return send(p, cmd).split("\r")[0]


def number(p, cmd):
    return float(token(p, cmd))


def signed24(v):
    return v - (1 << 24) if v & (1 << 23) else v


def plant_position(p, node):
    """The node's encoder count as the station reports it (feedback register 0, Y:$078420 +
    the node's slot, 5 fractional bits)."""
    slot = (node // 4) * 8 + (node % 2) * 4
    raw = int(token(p, f"RHY:${0x078420 + slot:06X}"), 16)
    return signed24(raw) / 32.0


@pytest.mark.parametrize("case", [pytest.param(c, id=c[3].__name__) for c in CASES])
def test_generated_homing_plc_zeroes_the_motor_at_the_switch_edge(ring, pmac, case):
    g, x, node, seq, edge = case
    state, status, grp = (f"P{PLC}00", f"P{PLC}01", f"P{PLC}02")
    send(pmac, f"{grp}={g} ENABLE PLC{PLC}")
    deadline = time.monotonic() + HOME_TIMEOUT
    while True:
        time.sleep(0.2)
        st, stat, active = (number(pmac, state), number(pmac, status),
                            token(pmac, f"M{x}45"))
        # the PLC disables itself at the end; done is state 7 (StateDone) with status 0
        if stat != 1 and st in (0, 7):
            break
        assert time.monotonic() < deadline, (st, stat, active)
    assert (st, stat) == (7, 0), f"{seq.__name__}: state {st}, status {stat}"
    assert token(pmac, f"M{x}45") == "1", "home complete"
    # at rest at the home position (Ixx26 = 0, no post-home move)
    time.sleep(0.5)
    pos = number(pmac, f"#{x}P")
    zero = plant_position(pmac, node) - pos
    assert abs(zero - edge) <= 1.0, f"{seq.__name__}: zero at plant count {zero}, edge {edge}"
