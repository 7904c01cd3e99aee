"""A card's hardware stop inputs (``Cluster.fault(CARD, "input", KIND)``, README "Card inputs
(abort/E-stop)"): the words are checked at once, and on a live PMAC2 card the JPAN STOP/
input aborts the selected C.S. as ``A`` does, until cleared."""

import time

import pytest

from pytest_mcc import INPUT_KINDS, INPUT_OPTIONS, UnknownChoice


@pytest.mark.mcc(cards=1, stations=1)
def test_input_faults_abort_the_selected_cs_and_clear(mcc_cluster):
    t = time.monotonic()
    with pytest.raises(UnknownChoice) as e:
        mcc_cluster.fault("card0", "input", "estop")
    assert e.value.choices == list(INPUT_KINDS) == ["abort", "feed-hold"]
    with pytest.raises(UnknownChoice) as e:
        mcc_cluster.fault("station0", "input", "abort")
    assert e.value.choices == ["card0"]
    with pytest.raises(UnknownChoice) as e:
        mcc_cluster.fault("card0", "input", "abort", probability=0.5)
    assert e.value.choices == list(INPUT_OPTIONS) == ["cs", "cycles"]
    with pytest.raises(UnknownChoice):
        mcc_cluster.fault("card0", "input")
    assert time.monotonic() - t < 1.0, "validated without asking the cluster"

    mcc_cluster.send(["#1J/", "&1#1->1000X", "OPEN PROG 1 CLEAR", "LINEAR INC TA100 TS0 F10",
                      "WHILE(1=1)", "X10", "ENDWHILE", "CLOSE", "&1B1R"])
    assert int(mcc_cluster.send("&1??")[:6], 16) & 1, "the program runs"
    out = mcc_cluster.fault("card0", "input", "abort", cs=1)
    assert "input abort active" in out and "FPD select 1" in out, out
    st = mcc_cluster.status()
    held = st.card(0)["inputs"]["held"]
    assert [h["kind"] for h in held] == ["abort"] and held[0]["select"] == 1, held
    mcc_cluster.wait_until(lambda s: s.cycle > held[0]["since"] + 400, timeout=60)
    assert int(mcc_cluster.send("&1??")[:6], 16) & 1 == 0, "?? program running cleared"
    w1 = int(mcc_cluster.send("#1?")[:6], 16)
    assert w1 & (1 << 18) == 0 and w1 & (1 << 13), f"motor 1 stopped closed-loop: {w1:06X}"
    mcc_cluster.clear("card0")
    assert mcc_cluster.status().card(0)["inputs"]["held"] == []
    mcc_cluster.send("&1B1R")
    assert int(mcc_cluster.send("&1??")[:6], 16) & 1, "runs again after the clear"
