"""The fixtures against real clusters: commands, ports, dls-pmaclib, synchronized starts,
gathering, faults and recovery, waits in ring cycles."""

import time

import pytest

from pytest_mcc import CardError, UnknownChoice, WaitTimeout

SETUP = ["&1#1->1000X", "#1J/", "OPEN PROG 1 CLEAR", "LINEAR INC F1000 TA20 TS0", "X2",
         "CLOSE", "I119=1"]


@pytest.mark.mcc(cards=2, stations=2)
def test_a_default_cluster_answers_on_every_card_and_port(mcc_cluster):
    st = mcc_cluster.status()
    assert st.locked and not st.faulted, st
    assert st["clock"] == "paced"
    assert st.member_names == ["card0", "station0", "card1", "station1"]
    assert mcc_cluster.send("I0", card=1) == "1"
    assert mcc_cluster.send(["I0", "P1=5 P1"], card=0) == ["0", "5"]
    with pytest.raises(CardError) as e:
        mcc_cluster.send("UUU", card=0)
    assert e.value.code == "ERR003" and e.value.card == 0
    assert mcc_cluster.send("UUU", card=0, check=False) == "ERR003"
    with pytest.raises(UnknownChoice) as e:
        mcc_cluster.send("I0", card=9)
    assert e.value.choices == [0, 1]
    p0, p1 = mcc_cluster.card(0).ports, mcc_cluster.card(1).ports
    assert len({p0.ascii, p0.pmac_eth, p1.ascii, p1.pmac_eth}) == 4
    with mcc_cluster.card(1).connect_ascii() as s:
        s.sendall(b"I0\r")
        assert s.recv(64).strip(b"\r\n\x06") == b"1"


@pytest.mark.mcc(cards=1, stations=1, profiles="turbo")
def test_pmaclib_gets_a_connected_interface(mcc_cluster):
    pytest.importorskip("dls_pmaclib")
    pmac = mcc_cluster.card(0).pmaclib()
    assert pmac.getPmacModelCode() == 602413
    reply, ok = pmac.sendCommand("P7=12 P7")
    assert ok and reply == "12\r\x06"
    telnet = mcc_cluster.card(0).pmaclib(kind="telnet")
    reply, ok = telnet.sendCommand("P7")
    assert ok and reply.startswith("12")


def test_start_sync_and_gather_put_both_cards_on_one_cycle(mcc_cluster_factory):
    c = mcc_cluster_factory(cards=2, stations=2)
    for n in (0, 1):
        c.send(SETUP, card=n)
    c.wait_cycles(300)  # the #1J/ of the set-up settles (a jog in progress refuses R)
    s = c.start_sync("&1B1R", cards=[0, 1])
    assert [k.executed_cycle for k in s.cards] == [s.cycle, s.cycle]
    assert [k.program_start_cycle for k in s.cards] == [s.cycle, s.cycle]
    st = c.status()
    assert [k["program_start_cycle"] for k in st["cards"]] == [s.cycle, s.cycle]
    # A start a card refuses (no program 9) raises, with the outcome attached.
    with pytest.raises(CardError) as e:
        c.start_sync("&1B9R")
    assert e.value.code.startswith("ERR") and e.value.detail.cycle > s.cycle
    assert [k.refusal for k in e.value.detail.cards] == [e.value.code] * 2
    # Gathering from one ring cycle on both cards, the jog started in that same tick.
    g = c.gather(motors=[1], cards=[0, 1], cycles=300, run="#1J=3000")
    assert len(g) == 301 and g.period == 1
    for n in (0, 1):
        t = g[n]
        assert t.cycle[0] == g.first_cycle and t.cycle[-1] == g.first_cycle + 300
        assert abs(t.commanded[1][-1] - t.commanded[1][0] - 3000) > 0  # it moved
    assert g[0].first_motion(1) == g[1].first_motion(1) is not None
    assert list(g[0].commanded[1]) == list(g[1].commanded[1])


def test_a_cut_fibre_is_seen_cleared_and_reset(mcc_cluster_factory):
    c = mcc_cluster_factory(cards=2, stations=2)
    out = c.fault("station0", "cut")
    assert "station0" in out
    st = c.wait_until(lambda st: st.broken_link == "station0 → card1"
                      and st.ring_faulted_cards() == [0, 1], cycles=20_000)
    assert st.member("station0")["faults"][0]["kind"] == "cut"
    assert all(k["motors_killed"] for k in st["cards"])
    c.clear()
    healthy = c.reset()
    assert healthy.locked and not healthy.faulted and healthy.ring_faulted_cards() == []
    assert c.send("I0", card=1) == "1"  # the cards work again after their $$$


def test_wait_until_counts_ring_cycles(mcc_cluster_factory):
    c = mcc_cluster_factory(cards=1, stations=1)
    first = c.wait_cycles(1)
    st = c.wait_cycles(200)
    assert st.cycle >= first.cycle + 200
    # A condition that never holds gives up after the stated cycles, not before.
    before = c.status().cycle
    with pytest.raises(WaitTimeout, match="within 500 ring cycles") as e:
        c.wait_until(lambda st: False, cycles=500)
    assert e.value.status.cycle >= before + 500
    # The message carries the last status, member by member, for a failure in CI.
    msg = str(e.value)
    assert f"last status: cycle {e.value.status.cycle}: locked=True" in msg
    assert "card0: locked, cycle" in msg and "station0: locked" in msg
    assert "card ring-fault bits 0=0" in msg
    start = c.status().cycle
    with pytest.raises(WaitTimeout, match="within 300 ring cycles"):
        c.wait_until(lambda: False, cycles=300, since=start)
    # A plain predicate: the status returned is taken after it held.
    calls = []
    t0 = c.status().cycle
    got = c.wait_until(lambda: calls.append(1) or len(calls) > 2, cycles=100_000)
    assert got.cycle > t0 and len(calls) == 3
    # Without a cycle bound, the wall-clock bound still ends the wait.
    t = time.monotonic()
    with pytest.raises(WaitTimeout, match="within 2 s"):
        c.wait_until(lambda st: False, timeout=2)
    assert time.monotonic() - t < 30
