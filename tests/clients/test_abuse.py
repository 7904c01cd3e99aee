"""Host-port abuse, bounded (the benchmark is `python tests/clients/abuse.py`): 500 concurrent
connections (garbage, oversized lines, half PMAC Ethernet packets, stalls, the heaviest legal
lines) on card0 of a cluster while a dls-pmaclib client is served."""

import abuse


def test_500_abusive_connections_leave_a_dls_client_served_and_the_ring_cycling():
    r = abuse.bench(connections=500, seconds=8.0, queries=100)
    print(abuse.text(r))
    # Every reply of the well-behaved client right, idle and under abuse.
    assert r["wrong_replies"] == [], r["wrong_replies"]
    assert r["client_idle"]["n"] == 100
    assert r["client_under_abuse"]["n"] >= 100
    # (Its round-trip times are reported, not asserted: wall-clock speed is the benchmark's.)
    # Every abuser kind really reached the card.
    for kind, s in r["abusers"].items():
        assert s["connections"] >= 100, (kind, s)
    assert r["abusers"]["heavy"]["received"] > 0
    # The card's memory stays bounded (500 heavy or oversized hosts held whole would be
    # hundreds of MB).
    assert r["card_rss_mb"]["peak"] - r["card_rss_mb"]["before"] < 150, r["card_rss_mb"]
    # The ring kept cycling without a fault.
    assert r["ring"]["cycles"] > 0
    assert not r["ring"]["faulted"]
    assert r["ring"]["members_with_new_ring_fault"] == []
