"""``send`` (issue 26 item 11): a line the card answers with nothing returns its empty reply;
only a line no card answered raises."""

import pytest

from pytest_mcc import MccError


@pytest.mark.mcc(cards=2, stations=1)
def test_a_line_answered_with_nothing_returns_an_empty_reply(mcc_cluster):
    c = mcc_cluster
    assert c.send("$$$", card=1) == ""
    assert c.send(["$$$", "I0"], card=1) == ["", "1"]
    assert c.send("$$$***", card=0) == ""
    assert c.send("I0", card=0) == "0"
    # No card 7 on the chain: nobody answered.
    with pytest.raises(MccError, match="no card answered '@7P1'"):
        c.send("@7P1")
    assert c.send("@7P1", check=False) == ""
