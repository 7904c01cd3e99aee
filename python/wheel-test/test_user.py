"""A user's first test file, as run right after ``pip install pytest-mcc`` with nothing else:
a cluster up, a jog, a cut fibre, down (``python/test-wheel.sh`` runs it in a fresh venv)."""

import os
import shutil

import pytest


def position(cluster, card: int) -> float:
    """Motor 1's actual position on ``card`` (``#1P``, counts)."""
    return float(cluster.send("#1P", card=card))


def test_a_jog_moves_and_a_cut_fibre_stops_the_ring(mcc_cluster_factory):
    c = mcc_cluster_factory(cards=2, stations=2)
    st = c.status()
    assert st.locked and not st.faulted, st.summary()
    # Every member runs from the one binary the wheel installed (no mcc-card, mcc-station).
    mcc = os.path.realpath(shutil.which("mcc"))
    for m in st["members"]:
        assert os.path.realpath(f"/proc/{m['pid']}/exe") == mcc, m

    c.send("#1J/", card=0)  # closed loop, holding
    start = position(c, 0)
    c.send("#1J=3000", card=0)
    c.wait_until(lambda: position(c, 0) > start + 100, cycles=20_000)

    c.fault("station1", "cut")  # the fibre from station1 to card0 breaks
    st = c.wait_until(lambda st: st.broken_link == "station1 → card0"
                      and st.ring_faulted_cards() == [0, 1], cycles=20_000)
    assert all(k["motors_killed"] for k in st["cards"])

    pids = [m["pid"] for m in st["members"]]
    c.stop()  # mcc down
    assert not c.running
    assert [p for p in pids if os.path.exists(f"/proc/{p}")] == []


@pytest.mark.mcc(cards=1, stations=1)
def test_the_fixture_cluster_answers(mcc_cluster):
    assert mcc_cluster.send("I0", card=0) == "0"
