"""Bad input: refused configs carry mcc's message, unknown faults and members raise at once
naming the valid choices, a cluster that does not lock raises with the member logs."""

import os
import subprocess
import time
from pathlib import Path

import pytest

from pytest_mcc import (DRILLS, FAULT_FAMILIES, FAULT_KINDS, LINK_KINDS, Cluster, ClusterStartError,
                        ConfigError, LockTimeout, UnknownChoice)
from pytest_mcc._procs import start_time


def _procs_with(marker: str):
    """Pids whose command line contains ``marker``."""
    found = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                cmd = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode()
            except OSError:
                continue
            if marker in cmd and start_time(int(d.name)) is not None:
                found.append(int(d.name))
    return found


def test_a_refused_config_raises_with_the_cli_message(mcc_cluster_factory):
    with pytest.raises(ConfigError, match=r'cards\[0\]\.profile: unknown profile "pmac3"'):
        mcc_cluster_factory(cards=1, stations=0, profiles="pmac3")
    with pytest.raises(ConfigError, match=r"stations\.station0: .*inertia: must be > 0"):
        mcc_cluster_factory(cards=1, stations=1, plant={"nodes": {"1": {"inertia": -1}}})
    with pytest.raises(ConfigError, match="nodez"):
        mcc_cluster_factory(config='[[cards]]\nname = "card0"\nnumber = 0\nmaster = 0\n'
                                   'nodez = [1]\n')
    with pytest.raises(ConfigError, match="sometimes"):
        mcc_cluster_factory(cards=1, stations=0, clock="sometimes")


def test_refusal_leaves_nothing_behind(mcc):
    c = Cluster(cards=1, stations=0, profiles="pmac3", mcc=mcc)
    with pytest.raises(ConfigError):
        c.start()
    assert not c.running and not c.run_base.exists()


@pytest.mark.mcc(cards=1, stations=1)
def test_unknown_faults_members_and_options_raise_at_once_with_the_choices(mcc_cluster):
    t = time.monotonic()
    with pytest.raises(UnknownChoice) as e:
        mcc_cluster.fault("station0", "melt")
    assert e.value.choices == list(FAULT_KINDS + DRILLS + FAULT_FAMILIES)
    assert "drop-sync" in str(e.value) and "freeze" in str(e.value) and "axis" in str(e.value)
    with pytest.raises(UnknownChoice) as e:
        mcc_cluster.fault("nobody", "cut")
    assert e.value.choices == ["card0", "station0"]
    with pytest.raises(UnknownChoice) as e:
        mcc_cluster.fault("station0", "cut", cycels=3)
    assert e.value.choices == ["cycles", "probability", "seed", "delay"]
    with pytest.raises(UnknownChoice) as e:
        mcc_cluster.fault("station0", "freeze", cycles=3)
    assert e.value.choices == []
    with pytest.raises(UnknownChoice):
        mcc_cluster.clear("nobody")
    with pytest.raises(UnknownChoice):
        mcc_cluster.card(4)
    assert time.monotonic() - t < 1.0, "validated without asking the cluster"
    # What only the cluster can judge still raises with its message.
    with pytest.raises(Exception, match="probability"):
        mcc_cluster.fault("station0", "corrupt", probability=1.5)
    assert mcc_cluster.status().locked


@pytest.mark.mcc(cards=1, stations=1)
def test_link_faults_check_targets_kinds_and_options_then_apply(mcc_cluster):
    t = time.monotonic()
    with pytest.raises(UnknownChoice) as e:
        mcc_cluster.fault("station0", "link", "short")
    assert e.value.choices == ["card0", "chain", "bus"]
    with pytest.raises(UnknownChoice) as e:
        mcc_cluster.fault("card0", "link", "melt")
    assert e.value.choices == list(LINK_KINDS)
    with pytest.raises(UnknownChoice) as e:
        mcc_cluster.fault("chain", "link", "bad-checksum")
    assert "bad-checksum" not in e.value.choices and "EMCL bus only" in str(e.value)
    with pytest.raises(UnknownChoice) as e:
        mcc_cluster.fault("card0", "link", "late", dealy=20)
    assert e.value.choices == ["cycles", "probability", "seed", "delay"]
    assert time.monotonic() - t < 1.0, "validated without asking the cluster"
    out = mcc_cluster.fault("card0", "link", "no-reply", probability=0.5, seed=1, cycles=4)
    assert "no-reply" in out, out
    f = mcc_cluster.status()["cards"][0]["link_fault"]
    assert (f["kind"], f["probability"], f["seed"], f["replies"]) == ("no-reply", 0.5, 1, 4)
    mcc_cluster.fault("chain", "link", "late", delay=20)
    assert mcc_cluster.status()["link_faults"]["chain"]["delay_ms"] == 20
    mcc_cluster.clear()
    doc = mcc_cluster.status()
    assert doc["cards"][0]["link_fault"] is None and doc["link_faults"]["chain"] is None


def test_the_python_fault_kinds_are_the_cli_s(mcc):
    # The kind is checked before the cluster is looked for: no cluster needed.
    out = subprocess.run([mcc, "--cluster", "nonesuch", "fault", "card0", "melt"],
                         capture_output=True, text=True, timeout=60)
    listed = out.stderr.split("expected one of:")[1].split(")")[0]
    words = [w.strip().split("=")[0] for w in listed.split(",")]
    assert words == list(FAULT_KINDS)


def test_a_cluster_that_does_not_lock_raises_with_the_member_logs(mcc, tmp_path):
    # A card binary that starts but never joins the ring (it only sleeps).
    marker = f"{os.getpid()}.{time.monotonic_ns() % 1000000}"
    slow = tmp_path / "bin"
    slow.mkdir()
    (slow / "mcc-card").write_text(
        f"#!/bin/sh\necho 'card wrapper: pretending to boot slowly' >&2\nexec sleep {marker}\n")
    # The real station: `mcc` runs the role itself (the wheel carries no mcc-station).
    (slow / "mcc-station").write_text(f'#!/bin/sh\nexec "{mcc}" run-station "$@"\n')
    for f in slow.iterdir():
        f.chmod(0o755)
    c = Cluster(cards=1, stations=1, mcc=mcc, lock_timeout=3, env={"MCC_BIN_DIR": str(slow)})
    t = time.monotonic()
    with pytest.raises(LockTimeout) as e:
        c.start()
    assert time.monotonic() - t < 60
    assert "did not lock within 3 s" in str(e.value)
    assert "pretending to boot slowly" in e.value.logs["card0"]
    assert "station0" in e.value.logs or "supervisor" in e.value.logs
    assert isinstance(e.value, ClusterStartError)
    assert _procs_with(f"sleep {marker}") == [], "the slow member was left running"
    assert not c.run_base.exists()
