"""Config building and CLI output parsing (no cluster needed)."""

import subprocess

import pytest

from pytest_mcc import ConfigError, LockTimeout, MccError, UnknownChoice
from pytest_mcc._cli import docs, error_from, strip_prefix
from pytest_mcc.config import build, parse_toml, to_toml

BASE = {
    "cluster": "mcc",
    "clock": "realtime",
    "rate_hz": 2258.7,
    "ring": {"name": "0", "order": ["card0", "station0", "card1", "station1"],
             "sync_master": "card0"},
    "cards": [
        {"name": "card0", "number": 0, "master": 0, "profile": "pmac2",
         "ivars": {"I1001": 16, "I1004": 2, "I1005": 4}},
        {"name": "card1", "number": 1, "master": 1, "profile": "pmac2",
         "ivars": {"I1001": 16, "I1004": 2, "I1005": 4}},
    ],
    "stations": [
        {"name": "station0", "master": 0, "nodes": [0, 1, 4, 5, 8, 9, 12, 13],
         "check": {"period": 8, "min_syncs": 4, "max_errors": 4}},
        {"name": "station1", "master": 1, "nodes": [0, 1, 4, 5, 8, 9, 12, 13],
         "check": {"period": 8, "min_syncs": 4, "max_errors": 4}},
    ],
}


def test_toml_round_trips_every_value_kind():
    doc = dict(BASE, extra_text='say "hi" \\ ünï\n', tiny=1.25e-05, big=float("inf"),
               flag=True, empty={})
    doc["stations"] = [dict(BASE["stations"][0],
                            plant={"mode": "torque", "nodes": {"1": {"inertia": 2e-5}}})]
    assert parse_toml(to_toml(doc)) == doc


def test_options_change_the_layout_and_leave_the_base_alone():
    doc = build(BASE, clock="lockstep", rate_hz=1000, profiles=["turbo", "pmac2"],
                ivars={"i1001": 8, "I130": 3000},
                plant={"coulomb": 0.0},
                plants={"station1": {"nodes": {"4": {"plus_limit": 5000}}}},
                drives=[{"name": "drive0", "address": 1, "station": "station0"}],
                extra={"rtf": 2.0})
    assert (doc["clock"], doc["rate_hz"], doc["rtf"]) == ("lockstep", 1000.0, 2.0)
    assert [c["profile"] for c in doc["cards"]] == ["turbo", "pmac2"]
    # The Turbo card does not get the PMAC2 ring-check defaults; the caller's ivars stay.
    assert doc["cards"][0]["ivars"] == {"i1001": 8, "I130": 3000}
    # One spelling per variable: the caller's i1001 replaces the default I1001.
    assert doc["cards"][1]["ivars"] == {"I1004": 2, "I1005": 4, "i1001": 8, "I130": 3000}
    assert doc["stations"][0]["plant"] == {"coulomb": 0.0}
    assert doc["stations"][1]["plant"] == {"coulomb": 0.0,
                                           "nodes": {"4": {"plus_limit": 5000}}}
    assert doc["drives"] == [{"name": "drive0", "address": 1, "station": "station0"}]
    assert "plant" not in BASE["stations"][0] and BASE["clock"] == "realtime"
    by_card = build(BASE, profiles={1: "turbo"}, ivars={"card0": {"I130": 1}})
    assert [c["profile"] for c in by_card["cards"]] == ["pmac2", "turbo"]
    assert by_card["cards"][0]["ivars"]["I130"] == 1 and "I130" not in by_card["cards"][1]["ivars"]


def test_bad_options_name_the_valid_choices():
    with pytest.raises(UnknownChoice) as e:
        build(BASE, plants={"station9": {}})
    assert e.value.choices == ["station0", "station1"]
    with pytest.raises(UnknownChoice) as e:
        build(BASE, profiles={7: "turbo"})
    assert 0 in e.value.choices and "card1" in e.value.choices
    with pytest.raises(ValueError, match="3 values for 2 cards"):
        build(BASE, profiles=["turbo"] * 3)


def test_json_documents_and_errors_are_read_from_the_cli_output():
    assert docs('{"a": 1}\n{"error": {"kind": "x"}}\n') == [{"a": 1}, {"error": {"kind": "x"}}]
    assert docs("") == [] and docs("not json") == []
    assert strip_prefix("mcc: ring 0: 1/2 locked\nmcc: error: config: bad\n") == "config: bad"

    def failed(stdout, stderr="", rc=1):
        return error_from(subprocess.CompletedProcess(["mcc"], rc, stdout, stderr), ["mcc"])

    e = failed('{"error": {"kind": "config", "message": "config: cards[0].profile: no", '
               '"logs": {}}}')
    assert isinstance(e, ConfigError) and "cards[0].profile" in str(e)
    e = failed('{"error": {"kind": "lock-timeout", "message": "did not lock", '
               '"logs": {"card0": "last words"}}}')
    assert isinstance(e, LockTimeout) and e.logs == {"card0": "last words"}
    assert "--- last lines of card0.log ---\nlast words" in str(e)
    e = failed("", "error: invalid value 'sometimes' for '--clock <MODE>'\n", rc=2)
    assert isinstance(e, ConfigError) and "sometimes" in str(e)
    e = failed("", "mcc: error: something else\n")
    assert type(e) is MccError and e.message == "something else"
