"""The homing routine against a station plant with a home switch (and limit switches) where
the test puts them. Run: ``pytest examples/homing``."""

import pytest

from homing_routine import HomingFailed, MotorStatus, home

#: Motor 1 of card 0 is servo node 0 of station0; its home switch is 500 counts wide.
SWITCH = {"nodes": {"0": {"home_position": 12000, "home_width": 500}}}


def test_status_bits():
    st = MotorStatus.parse("800000000401")
    assert st.home_complete and st.in_position and not st.positive_limit


def test_homes_onto_the_switch(mcc_cluster_factory):
    c = mcc_cluster_factory(cards=1, stations=1, plants={"station0": SWITCH})
    send = lambda line: c.send(line, card=0)  # noqa: E731 - the routine's transport
    send("#1J/")
    c.wait_cycles(200)
    pos = home(send, motor=1, speed=32)
    # Motor zero is now the switch edge: the motor settled there (within the deadband).
    assert abs(pos) < 10, pos
    # Going back to where it started is 12000 counts the other way.
    send("I122=64 #1J=-12000")
    c.wait_until(lambda: abs(float(send("#1P")) + 12000) < 10, cycles=50_000)
    # Homing again from there finds the same edge.
    assert abs(home(send, motor=1, speed=32)) < 10


def test_a_limit_switch_before_the_home_switch_fails_the_search(mcc_cluster_factory):
    limits = {"nodes": {"0": {"home_position": 12000, "plus_limit": 6000}}}
    c = mcc_cluster_factory(cards=1, stations=1, plants={"station0": limits})
    send = lambda line: c.send(line, card=0)  # noqa: E731
    send("#1J/")
    with pytest.raises(HomingFailed, match="positive limit"):
        home(send, motor=1, speed=32)


def test_homing_in_the_negative_direction(mcc_cluster_factory):
    switch = {"nodes": {"0": {"home_position": -9000, "home_width": 400}}}
    c = mcc_cluster_factory(cards=1, stations=1, plants={"station0": switch})
    send = lambda line: c.send(line, card=0)  # noqa: E731
    send("#1J/")
    assert abs(home(send, motor=1, speed=-32)) < 10
