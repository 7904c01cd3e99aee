"""Axis faults through the plugin: every word checked at once against the cluster's stations
and servo nodes (UnknownChoice naming the valid ones), the kinds the CLI's, and a fault seen
by the card, shown in the status and cleared."""

import subprocess
import time

import pytest

from pytest_mcc import AXIS_KINDS, AXIS_VALUE_KINDS, ConfigError, UnknownChoice
from pytest_mcc.axis import axis_args, power_loss_args

STATUS = {"stations": [{"name": "station0", "nodes": [0, 1, 4, 5]},
                       {"name": "station1", "nodes": [8]}]}


def test_axis_words_become_the_cli_s():
    assert axis_args(STATUS, "station0", (4, "load"), {"value": -0.5, "cycles": 30}) == [
        "fault", "station0", "axis", "4", "load", "--cycles", "30", "--value", "-0.5"]
    assert axis_args(STATUS, "station1", (8, "jam"), {}) == [
        "fault", "station1", "axis", "8", "jam"]
    assert power_loss_args(STATUS, "station0", (), {"cycles": 5}) == [
        "fault", "station0", "power-loss", "--cycles", "5"]


def test_bad_axis_words_raise_with_the_choices():
    def choices(*args):
        with pytest.raises(UnknownChoice) as e:
            axis_args(STATUS, *args)
        return e.value.choices
    assert choices("station7", (0, "jam"), {}) == ["station0", "station1"]
    assert choices("station0", (8, "jam"), {}) == [0, 1, 4, 5]
    assert choices("station0", ("0", "jam"), {}) == [0, 1, 4, 5]
    assert choices("station0", (0, "melt"), {}) == list(AXIS_KINDS)
    assert choices("station0", (0, "jam"), {"value": 3}) == ["cycles"]
    assert choices("station0", (0, "load"), {"cylces": 3}) == ["cycles", "value"]
    with pytest.raises(ConfigError, match="needs value"):
        axis_args(STATUS, "station0", (0, "encoder-glitch"), {})
    with pytest.raises(ConfigError, match="at least 1"):
        axis_args(STATUS, "station0", (0, "jam"), {"cycles": 0})
    with pytest.raises(UnknownChoice):
        power_loss_args(STATUS, "station0", (), {"value": 1})


def test_the_python_axis_kinds_are_the_cli_s(mcc):
    out = subprocess.run([mcc, "fault", "--help"], capture_output=True, text=True, timeout=60)
    for k in AXIS_KINDS + ("power-loss",):
        assert k in out.stdout, k
    for k in AXIS_VALUE_KINDS:
        out = subprocess.run([mcc, "--cluster", "nonesuch", "fault", "station0", "axis", "0", k],
                             capture_output=True, text=True, timeout=60)
        assert "needs --value" in out.stderr, out.stderr


W1_OPEN_LOOP = 1 << 18
W2_AMP_FAULT = 1 << 3


@pytest.mark.mcc(cards=1, stations=1, clock="lockstep")
def test_an_amp_fault_kills_the_motor_shows_and_clears(mcc_cluster):
    c = mcc_cluster
    t = time.monotonic()
    with pytest.raises(UnknownChoice) as e:
        c.fault("station0", "axis", 2, "amp-fault")
    assert e.value.choices == [0, 1, 4, 5, 8, 9, 12, 13]
    with pytest.raises(UnknownChoice):
        c.fault("card0", "axis", 0, "amp-fault")
    assert time.monotonic() - t < 1.0, "validated without asking the cluster"

    def words(motor=1):
        r = c.send(f"#{motor}?", card=0)
        return int(r[:6], 16), int(r[6:12], 16)

    c.send("I3=2", card=0)
    c.send("#1J/", card=0)
    c.wait_cycles(100)
    assert not words()[0] & W1_OPEN_LOOP
    assert "node 0 amp-fault" in c.fault("station0", "axis", 0, "amp-fault")
    c.wait_until(lambda: words()[1] & W2_AMP_FAULT and words()[0] & W1_OPEN_LOOP,
                 cycles=2000)
    f = c.status()["stations"][0]["axis_faults"]
    assert [(x["node"], x["kind"]) for x in f] == [(0, "amp-fault")]
    c.clear("station0")
    c.wait_cycles(5)
    assert c.status()["stations"][0]["axis_faults"] == []
    c.send("#1J/", card=0)
    c.wait_cycles(100)
    w1, w2 = words()
    assert not w1 & W1_OPEN_LOOP and not w2 & W2_AMP_FAULT
