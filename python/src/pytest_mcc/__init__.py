"""pytest-mcc: test PMAC/MACRO host software against an mcc cluster.

A pytest plugin (fixtures ``mcc_cluster`` and ``mcc_cluster_factory``, marker ``mcc``) over
the ``mcc`` command-line tool and its JSON contracts, and the :class:`Cluster` class it is
built on for use outside pytest::

    from pytest_mcc import Cluster

    with Cluster(cards=2, stations=2, clock="lockstep") as c:
        c.send("#1J=1000", card=0)
        c.wait_until(lambda st: ..., cycles=5000)
"""

from importlib import metadata as _metadata

from .axis import AXIS_KINDS, AXIS_VALUE_KINDS
from .card import Card, Ports
from .cluster import (DRILLS, FAULT_FAMILIES, FAULT_KINDS, FAULT_OPTIONS, INPUT_KINDS, INPUT_OPTIONS, LINK_KINDS,
                      CardStart, Cluster, Recording, SyncStart, stop_all)
from .errors import (
    CardError,
    ClusterBusy,
    ClusterStartError,
    ConfigError,
    LockTimeout,
    MccError,
    MccNotFound,
    UnknownChoice,
    WaitTimeout,
)
from .gather import Gathered, Trace
from .status import Status

__all__ = [
    "AXIS_KINDS", "AXIS_VALUE_KINDS", "Card", "CardError", "CardStart", "Cluster", "ClusterBusy", "ClusterStartError",
    "ConfigError", "DRILLS", "FAULT_FAMILIES", "FAULT_KINDS", "FAULT_OPTIONS", "Gathered", "INPUT_KINDS", "INPUT_OPTIONS", "LINK_KINDS", "LockTimeout",
    "MccError", "MccNotFound", "Ports", "Recording", "Status", "SyncStart", "Trace", "UnknownChoice",
    "WaitTimeout", "stop_all",
]
try:
    #: The installed distribution's version (the wheel's is the mcc workspace's).
    __version__ = _metadata.version("pytest-mcc")
except _metadata.PackageNotFoundError:  # imported from a source tree, not installed
    __version__ = "0+unknown"
