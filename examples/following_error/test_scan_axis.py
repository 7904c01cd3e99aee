"""The scan mover against a station plant whose axis develops a following error during the
move: a load torque on the motor (a sticking stage) or a jam (a hard stop). The mover must
stop the scan and raise FollowingErrorTrip for the right motor, and a cleared fault plus the
PMAC recovery (``#nJ/``) must let the scan finish. Run: ``pytest examples/following_error``.
"""

import pytest

from scan_axis import FollowingErrorTrip, ScanAxes

#: The mover must raise within this many ring cycles of the fault (4.4 s of ring time at
#: 2258.7 Hz): the following error reaches Ixx11 (2000 counts) some 300 cycles into a jam at
#: 16 counts/ms and the card kills at once; the rest is the host's polling over TCP, which a
#: loaded machine slows (the ring keeps wall time).
N = 10_000


def scan(c):
    axes = ScanAxes(c.card(0).pmaclib(), motors=(1, 2))
    axes.enable()
    c.wait_cycles(100)
    return axes


#: A stage that sticks for 200 cycles (0.3 N·m against a motor whose amplifier gives 4 N·m
#: at full scale), and one that jams until cleared.
FAULTS = [("load", {"value": 0.3, "cycles": 200}), ("jam", {})]


@pytest.mark.parametrize("kind,opts", FAULTS, ids=[k for k, _ in FAULTS])
def test_a_following_error_during_the_scan_stops_it(mcc_cluster_factory, kind, opts):
    c = mcc_cluster_factory(cards=1, stations=1)
    axes = scan(c)
    axes.start({1: 40_000, 2: 40_000})
    c.wait_cycles(300)                         # both axes under way
    before = c.status().cycle
    c.fault("station0", "axis", 0, kind, **opts)   # motor 1 is node 0 of station0
    with pytest.raises(FollowingErrorTrip) as trip:
        axes.wait(timeout=30)
    now = c.status().cycle
    assert trip.value.motor == 1
    assert now - before <= N, f"raised {now - before} cycles after the fault"
    # Motor 2 stopped short of its target with motor 1 (the mover killed it). Motor 1 stays
    # where the jam holds it, or runs away under the load once its amplifier is off.
    assert trip.value.positions[2] < 40_000 - 1_000, trip.value
    w1 = int(c.send("#2?", card=0)[:6], 16)
    assert w1 & (1 << 18), "motor 2 killed too"
    if kind == "jam":
        assert trip.value.positions[1] < 40_000 - 1_000, trip.value

    # The fault cleared, the killed motors coast to a stop, the PMAC recovery (#nJ/), and
    # the scan finishes from where the axes are (motor 1 backs off: a runaway under the load
    # may have ended past its +limit switch, which blocks + moves).
    c.clear("station0")
    c.wait_until(lambda: abs(float(c.send("#1V", card=0))) < 0.1, cycles=100_000)
    axes.enable()
    c.wait_cycles(100)
    here = float(c.send("#1P", card=0))
    axes.start({1: here - 2_000, 2: 40_000})
    done = axes.wait(timeout=60)
    assert abs(done[1] - here + 2_000) < 20 and abs(done[2] - 40_000) < 20, done


def test_the_scan_finishes_without_a_fault(mcc_cluster_factory):
    c = mcc_cluster_factory(cards=1, stations=1)
    axes = scan(c)
    axes.start({1: 5_000, 2: -5_000})
    done = axes.wait(timeout=60)
    assert abs(done[1] - 5_000) < 20 and abs(done[2] + 5_000) < 20, done
