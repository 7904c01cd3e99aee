"""One card of a running cluster: its host ports, commands addressed to it, and a
dls-pmaclib client connected to its PMAC Ethernet port."""

from __future__ import annotations

import socket
from typing import TYPE_CHECKING, Any, NamedTuple, Optional, Sequence, Union

from .errors import MccError

if TYPE_CHECKING:  # pragma: no cover
    from .cluster import Cluster


class Ports(NamedTuple):
    """TCP ports of a card on 127.0.0.1."""

    #: ASCII terminal port (raw TCP, like a terminal server on the serial port).
    ascii: int
    #: PMAC Ethernet protocol port (VR_ packets: what dls-pmaclib and other PMAC tools speak).
    pmac_eth: int


class Card:
    """Card number :attr:`number` (I0) of a cluster."""

    def __init__(self, cluster: "Cluster", number: int) -> None:
        self.cluster = cluster
        self.number = number

    def __repr__(self) -> str:
        return f"<Card {self.number} of cluster {self.cluster.name}>"

    @property
    def name(self) -> str:
        """Member name (e.g. ``card0``)."""
        assert self.cluster.initial_status is not None
        return str(self.cluster.initial_status.card(self.number)["name"])

    @property
    def ports(self) -> Ports:
        """Its ports now (a restarted card listens on new ports)."""
        row = self.cluster.status().card(self.number)
        if row.get("ascii") is None or row.get("pmac_eth") is None:
            raise MccError(f"card {self.number} reports no ports (is it running?)")
        return Ports(int(row["ascii"]), int(row["pmac_eth"]))

    def send(self, line: Union[str, Sequence[str]], **kw: Any) -> Any:
        """:meth:`Cluster.send` addressed to this card."""
        return self.cluster.send(line, card=self.number, **kw)

    def connect_ascii(self, timeout: float = 5.0) -> socket.socket:
        """A TCP connection to its ASCII terminal port (closed when the cluster stops)."""
        s = socket.create_connection(("127.0.0.1", self.ports.ascii), timeout=timeout)
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.cluster._closers.append(s.close)
        return s

    def pmaclib(self, timeout: float = 5.0, kind: str = "ethernet") -> Any:
        """A connected dls-pmaclib interface to this card (disconnected when the cluster
        stops): ``PmacEthernetInterface`` on its PMAC Ethernet port (``kind="ethernet"``), or
        ``PmacTelnetInterface`` on its ASCII port (``kind="telnet"``).

        Needs the ``dls-pmaclib`` package (``pip install 'pytest-mcc[pmaclib]'``). Note that
        connecting sets I3 = 2 and I6 = 1 on the card, as dls-pmaclib does on a real PMAC.
        """
        try:
            from dls_pmaclib.dls_pmacremote import (PmacEthernetInterface,
                                                    PmacTelnetInterface)
        except ImportError as e:
            raise MccError("card(n).pmaclib() needs dls-pmaclib: "
                           "pip install 'pytest-mcc[pmaclib]' (or dls-pmaclib)") from e
        ports = self.ports
        if kind == "ethernet":
            pmac = PmacEthernetInterface(timeout=timeout)
            pmac.setConnectionParams("127.0.0.1", ports.pmac_eth)
        elif kind == "telnet":
            pmac = PmacTelnetInterface(timeout=timeout)
            pmac.setConnectionParams("127.0.0.1", ports.ascii)
        else:
            from .errors import UnknownChoice
            raise UnknownChoice("dls-pmaclib interface", kind, ["ethernet", "telnet"])
        err: Optional[str] = pmac.connect()
        if err is not None:
            raise MccError(f"dls-pmaclib could not connect to card {self.number}: {err}")
        self.cluster._closers.append(pmac.disconnect)
        return pmac
