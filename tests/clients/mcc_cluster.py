"""A running cluster for the host-client tests: `mcc up --detach` in a private run directory,
driven with `mcc` verbs, `mcc down` at the end. Every wait is bounded."""

import json
import os
import re
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MCC_BIN = os.environ.get("MCC_BIN", str(ROOT / "target" / "debug" / "mcc"))
UP_TIMEOUT = 240
VERB_TIMEOUT = 120
SCRUB = ("MCC_BIN_DIR", "MCC_CHAIN_PTY", "MCC_CHAIN_PORT", "MCC_EMCL_PTY", "MCC_EMCL_PORT")


class Cluster:
    """`mcc up --detach --cluster <tag><pid> <up_args…>` in a private run directory."""

    def __init__(self, tag, *up_args):
        self.run_dir = tempfile.mkdtemp(prefix=f"mcc-{tag}-")
        self.name = f"{tag}{os.getpid()}"
        self.env = {k: v for k, v in os.environ.items() if k not in SCRUB}
        self.env["MCC_RUN_DIR"] = self.run_dir
        try:
            self.mcc("up", "--detach", *up_args, "--timeout", "150", timeout=UP_TIMEOUT)
        except BaseException:
            self.stop()
            raise

    def mcc(self, *args, timeout=VERB_TIMEOUT):
        """`mcc --cluster NAME args…`; its stdout (a RuntimeError with stderr if it fails)."""
        out = subprocess.run([MCC_BIN, "--cluster", self.name, *args], env=self.env,
                             stdin=subprocess.DEVNULL, capture_output=True, text=True,
                             timeout=timeout)
        if out.returncode != 0:
            raise RuntimeError(f"mcc {args}: {out.stderr}")
        return out.stdout

    def status(self):
        return json.loads(self.mcc("status", "--json"))

    def stop(self):
        try:
            self.mcc("down", "--timeout", "10")
        except RuntimeError:
            pass
        finally:
            shutil.rmtree(self.run_dir, ignore_errors=True)


def turbo_ring_config(tmp_path, stations, plant=""):
    """The default layout (`mcc up --print-config`) with one Turbo card and `stations`
    stations, without the PMAC2 ring-check I-variables (they do not exist on a Turbo card);
    `plant` (TOML tables) goes into the first station, right after its check table."""
    text = subprocess.run([MCC_BIN, "up", "--print-config", "--cards", "1", "--stations",
                           str(stations)], capture_output=True, text=True, check=True,
                          timeout=60).stdout
    text = text.replace('profile = "pmac2"', 'profile = "turbo"')
    text = re.sub(r"\[cards\.ivars\]\n(I10\d\d = \d+\n)+", "", text)
    assert 'profile = "turbo"' in text and "I1001" not in text, text
    text = text.replace("max_errors = 4\n", "max_errors = 4\n" + plant, 1)
    path = tmp_path / "turbo.toml"
    path.write_text(text)
    return path


def turbo_cluster(tag, tmp_path, stations, plant=""):
    """A running cluster of `turbo_ring_config(tmp_path, stations, plant)`."""
    return Cluster(tag, "--config", str(turbo_ring_config(tmp_path, stations, plant)))


def wait_for(what, f, timeout=120.0):
    """Poll f() every 50 ms until it is truthy (ring time may run slower than wall time)."""
    deadline = time.monotonic() + timeout
    while True:
        v = f()
        if v:
            return v
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.05)
