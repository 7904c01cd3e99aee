"""EDB step drives (``[[drives]]``) in a factory cluster: the factory's ``drives`` replace the
layout's (the embedded default has ``drive0`` on station0), and the cluster serves them on
its EMCL bus. Skipped only against an ``mcc`` older than ``[[drives]]``."""

import subprocess

import pytest

DRIVES = [{"name": "drive7", "address": 7, "station": "station0"}]


def _mcc_knows_drives(mcc: str) -> bool:
    toml = ('[[cards]]\nname = "card0"\nnumber = 0\nmaster = 0\n'
            '[[stations]]\nname = "station0"\nmaster = 0\n'
            '[[drives]]\nname = "drive7"\naddress = 7\nstation = "station0"\n')
    out = subprocess.run([mcc, "up", "--print-config", "--config", "/dev/stdin"],
                         input=toml, capture_output=True, text=True, timeout=60)
    return out.returncode == 0


def test_drives_reach_the_cluster_and_its_emcl_bus(mcc, mcc_cluster_factory):
    if not _mcc_knows_drives(mcc):
        pytest.skip("this mcc does not know [[drives]] (older than the EMCL drives)")
    c = mcc_cluster_factory(cards=1, stations=1, drives=DRIVES)
    assert c.config["drives"] == DRIVES
    st = c.status()
    assert isinstance(st["emcl_bus"], str) and st["emcl_bus"].startswith("127.0.0.1:"), st
    assert [(d["name"], d["address"], d["host"]) for d in st["drives"]] == [
        ("drive7", 7, "station0")]
