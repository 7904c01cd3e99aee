"""Both axes of a two-card scan start on the same ring cycle. Run:
``pytest examples/sync_scan``."""

import pytest

import scan


@pytest.mark.mcc(cards=2, stations=2)
def test_both_axes_start_on_the_same_cycle(mcc_cluster):
    chain = scan.DaisyChain(mcc_cluster.daisy_chain)
    try:
        scan.load(chain, cards=[0, 1], distance=2, feed=4)
        # Record both motors from one ring cycle while the host software starts the scan.
        with mcc_cluster.gathering(motors=[1], cards=[0, 1], cycles=3000) as rec:
            scan.start(chain, cards=[0, 1])
    finally:
        chain.close()
    data = rec.result()
    first = [data[n].first_motion(1) for n in (0, 1)]
    assert first[0] is not None, "the scan did not move within the recording"
    assert first[0] == first[1], f"axes started on ring cycles {first}"
    # The cards agree: both programs started in that tick.
    st = mcc_cluster.status()
    starts = [c["program_start_cycle"] for c in st["cards"]]
    assert starts[0] == starts[1] and starts[0] <= first[0]
    # And the two trajectories are the same, sample for sample.
    assert list(data[0].commanded[1]) == list(data[1].commanded[1])
