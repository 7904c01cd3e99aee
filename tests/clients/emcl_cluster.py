"""A running cluster with an EMCL bus for the TMCL client tests: `mcc up --detach --clock lockstep
--cards 1 --stations 1 --pty` in a private run directory (drive0 at address 1 on station0), its
TCP port and pty from `mcc status --json`, `mcc down` at the end. Every wait is bounded."""

import json
import os
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


class EmclCluster:
    """One cluster; `tcp` is "127.0.0.1:PORT", `pty` the bus's pseudo-terminal path."""

    def __init__(self):
        self.run_dir = tempfile.mkdtemp(prefix="mcc-tmcl-")
        self.name = f"tmcl{os.getpid()}"
        self.env = {k: v for k, v in os.environ.items() if k not in SCRUB}
        self.env["MCC_RUN_DIR"] = self.run_dir
        self.mcc("up", "--detach", "--clock", "lockstep", "--cards", "1", "--stations", "1",
                 "--pty", "--timeout", "150", timeout=UP_TIMEOUT)
        doc = self.status()
        self.tcp = doc["emcl_bus"]
        self.pty = doc["emcl_bus_pty"]
        assert self.tcp and self.pty, doc

    def mcc(self, *args, timeout=VERB_TIMEOUT):
        out = subprocess.run([MCC_BIN, "--cluster", self.name, *args], env=self.env,
                             stdin=subprocess.DEVNULL, capture_output=True, text=True,
                             timeout=timeout)
        if out.returncode != 0:
            raise RuntimeError(f"mcc {args}: {out.stderr}")
        return out.stdout

    def status(self):
        return json.loads(self.mcc("status", "--json"))

    def drive(self, name="drive0"):
        return next(d for d in self.status()["drives"] if d["name"] == name)

    def input(self, *settings):
        self.mcc("emcl", "input", "drive0", *settings)

    def stop(self):
        try:
            self.mcc("down", "--timeout", "10")
        finally:
            shutil.rmtree(self.run_dir, ignore_errors=True)


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
