"""A running cluster with an EMCL bus for the TMCL client tests: `mcc up --detach --clock lockstep
--cards 1 --stations 1 --pty` in a private run directory (drive0 at address 1 on station0), its
TCP port and pty from `mcc status --json`, `mcc down` at the end. Every wait is bounded."""

from mcc_cluster import Cluster, wait_for

__all__ = ["EmclCluster", "wait_for"]


class EmclCluster(Cluster):
    """One cluster; `tcp` is "127.0.0.1:PORT", `pty` the bus's pseudo-terminal path."""

    def __init__(self):
        super().__init__("tmcl", "--clock", "lockstep", "--cards", "1", "--stations", "1",
                         "--pty")
        doc = self.status()
        self.tcp = doc["emcl_bus"]
        self.pty = doc["emcl_bus_pty"]
        assert self.tcp and self.pty, doc

    def drive(self, name="drive0"):
        return next(d for d in self.status()["drives"] if d["name"] == name)

    def input(self, *settings):
        self.mcc("emcl", "input", "drive0", *settings)
