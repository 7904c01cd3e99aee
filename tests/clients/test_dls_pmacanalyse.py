"""dls-pmacanalyse (Diamond's PMAC backup/compare tool, from PyPI) reads a whole Turbo PMAC
with MACRO stations back over PMAC Ethernet: a Turbo card on a ring with two 16-axis MACRO
stations. Its MACRO station section is what the stations hold: the per-node flag-capture
variables of every active node (I6841) and the global station variables of station 0, each
read with `ms{node},i{var}` over the ring's Type 1 auxiliary channel; variables a station
does not have are refused (ERR008) and left out, as the tool expects."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

from mcc_cluster import turbo_cluster

#: The tool reads one card in ~20 s unloaded; a generous bound for a loaded machine.
ANALYSE_TIMEOUT = 900


@pytest.fixture(scope="module")
def turbo_ring(tmp_path_factory):
    c = turbo_cluster("pmacanalyse", tmp_path_factory.mktemp("cfg"), 2)
    yield c
    c.stop()


def section(text, title):
    """The lines of backup-file section `; <title>` up to the next blank line (or the end)."""
    lines = text.splitlines()
    start = lines.index(f"; {title}") + 1
    end = lines.index("", start) if "" in lines[start:] else len(lines)
    return lines[start:end]


def test_dls_pmacanalyse_reads_the_macro_stations_back(turbo_ring, tmp_path):
    # A station set-up to find again: station 0's configuration number, node 4 capturing on
    # the falling edge (MI912 = 14), nodes 5 and 8 (station 1) on other flags (MI913).
    for line in ("MS CONFIG0=37", "MS4,MI912=14", "MS5,MI913=1", "MS8,MI913=2"):
        turbo_ring.mcc("send", "--card", "0", line)
    port = turbo_ring.status()["cards"][0]["pmac_eth"]
    backup, results = tmp_path / "backup", tmp_path / "results"
    backup.mkdir()
    results.mkdir()
    # The 3.0.0 console script's argument parser refuses the tool's own options: run its
    # main() with them, as the console script of earlier releases did.
    run = (
        "import sys\n"
        "from dls_pmacanalyse.dls_pmacanalyse import main\n"
        "sys.argv = ['dls-pmacanalyse'] + sys.argv[1:]\n"
        "main()\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", run, f"--backup={backup}", f"--resultsdir={results}",
         "--pmac=card0", f"--tcpip=127.0.0.1:{port}", "--loglevel=info"],
        capture_output=True, text=True, timeout=ANALYSE_TIMEOUT, cwd=tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "Reading macro station I-variables" in out.stdout + out.stderr, out.stderr
    pmc = (backup / "card0.pmc").read_text()

    # Per node: every node of the card's ring (I6841 = $F3333: 0, 1, 4, 5, 8, 9, 12, 13)
    # answers the encoder decode (MI910, the plant's x4 quadrature), the flag-capture control
    # and select (MI912, MI913) and the output mode (MI916) it holds; MI911, MI914-MI915 and
    # MI917-MI930 are not variables of these stations (ERR008) and are left out.
    nodes = [0, 1, 4, 5, 8, 9, 12, 13]
    want = {n: (2, 0) for n in nodes}
    want[4] = (14, 0)
    want[5] = (2, 1)
    want[8] = (2, 2)
    expected = []
    for n in nodes:
        expected += [f"ms{n},i910=7", f"ms{n},i912={want[n][0]}", f"ms{n},i913={want[n][1]}",
                     f"ms{n},i916=0"]
    assert section(pmc, "Macro station I-variables") == expected

    # Global: station 0's firmware version, configuration number, ring check settings and
    # ring words; the read-only ones as comments. Stations 16 and 48 (MACRO ICs 1 and 3, not
    # on this card) are refused with ERR003 and left out.
    glob = section(pmc, "Macro station global I-variables")
    for line in ("ms0,i0=1.104", "ms0,i2=37", "ms0,i6=0", "ms0,i8=8", "ms0,i9=4",
                 "ms0,i10=4", "ms0,i995=32896", ";ms0,i4=0", ";ms0,i5=0", ";ms0,i12=0"):
        assert line in glob, glob
    assert not [g for g in glob if re.match(r";?ms(16|48),", g)], glob
    # The HTML pages of the MACRO station section.
    page = (results / "card0_msivars_glob.htm").read_text()
    assert "Global Macrostation I Variables for card0" in page
    assert Path(results / "card0_msivariables.htm").exists()
