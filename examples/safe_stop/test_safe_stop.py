"""The safe-stop routine must notice a MACRO ring fault and report it within N ring cycles
of the controller latching it. Run: ``pytest examples/safe_stop``."""

import pytest

from ring_watch import SafeStop, ring_fault

#: Requirement: report within this many ring cycles of the fault (0.44 s of ring time at the
#: PMAC's 2258.7 Hz servo rate).
N = 1000


def test_global_status_parsing():
    assert ring_fault("000010000800\r\x06")
    assert not ring_fault("000000000800\r\x06")
    assert not ring_fault("\x07ERR003\r")


@pytest.mark.mcc(cards=2, stations=2)
def test_a_ring_fault_is_reported_within_n_cycles(mcc_cluster):
    reports = []
    pmacs = {f"card{n}": mcc_cluster.card(n).pmaclib() for n in (0, 1)}
    monitor = SafeStop(pmacs, reports.append).start()
    try:
        mcc_cluster.wait_cycles(500)
        assert reports == [] and monitor.errors == [], "a healthy ring reports nothing"

        mcc_cluster.fault("station1", "cut")  # the fibre from station1 to card0 breaks
        st = mcc_cluster.wait_until(lambda: reports, cycles=20 * N)
    finally:
        monitor.stop()

    latched = min(st.member(c)["ring_fault_cycle"] for c in ("card0", "card1")
                  if st.member(c)["ring_fault_cycle"] is not None)
    assert st.cycle - latched <= N, f"reported {st.cycle - latched} cycles after the fault"
    assert reports[0].controller in pmacs
    assert sorted(reports[0].stopped) == ["card0", "card1"]
    # And the cluster agrees on where the fibre broke.
    mcc_cluster.wait_until(lambda st: st.broken_link == "station1 → card0", cycles=5000)


@pytest.mark.mcc(cards=2, stations=2)
def test_no_report_without_a_fault(mcc_cluster):
    reports = []
    monitor = SafeStop({"card0": mcc_cluster.card(0).pmaclib()}, reports.append).start()
    try:
        mcc_cluster.wait_cycles(3000)
    finally:
        monitor.stop()
    assert reports == [] and monitor.errors == []
