"""Results of :meth:`Cluster.gather`: positions recorded by the cards' own data gathering
(``mcc gather --json``), stamped with ring cycles.

Columns are numpy arrays when numpy is installed, else :class:`array.array` (``'d'`` for
positions, ``'q'`` for cycles); both index, slice and iterate the same way, and
``numpy.asarray`` takes either.
"""

from __future__ import annotations

from array import array
from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Sequence

try:  # pragma: no cover - depends on the environment
    import numpy as _np
except ImportError:  # pragma: no cover
    _np = None


def _col(values: Sequence[float], typecode: str) -> Any:
    if _np is not None:
        return _np.asarray(values, dtype=_np.int64 if typecode == "q" else _np.float64)
    return array(typecode, values)


@dataclass
class Trace:
    """One card's recording."""

    #: Card number (I0).
    card: int
    #: Ring cycle of every sample.
    cycle: Any
    #: Commanded position per motor, counts.
    commanded: Dict[int, Any]
    #: Actual (encoder) position per motor, counts.
    actual: Dict[int, Any]
    #: Servo cycle length, ms.
    cycle_ms: float

    def following_error(self, motor: int) -> List[float]:
        """Commanded minus actual position of ``motor`` at every sample."""
        return [c - a for c, a in zip(self.commanded[motor], self.actual[motor])]

    def first_motion(self, motor: int, threshold: float = 0.5,
                     column: str = "commanded") -> Optional[int]:
        """Ring cycle of the first sample where ``motor``'s position (``commanded`` or
        ``actual``) has left its first value by more than ``threshold`` counts; None if it
        never does."""
        data = getattr(self, column)[motor]
        if len(data) == 0:
            return None
        start = data[0]
        for cyc, v in zip(self.cycle, data):
            if abs(v - start) > threshold:
                return int(cyc)
        return None


@dataclass
class Gathered:
    """A gather on one or more cards started in the same ring cycle."""

    #: Ring cycle of sample 0 on every card.
    first_cycle: int
    #: Servo cycles between samples.
    period: int
    #: Motors recorded.
    motors: List[int]
    #: Per card number.
    cards: Dict[int, Trace] = field(default_factory=dict)

    def __getitem__(self, card: int) -> Trace:
        return self.cards[card]

    def __len__(self) -> int:
        first = next(iter(self.cards.values()), None)
        return 0 if first is None else len(first.cycle)

    @classmethod
    def from_json(cls, doc: Mapping[str, Any]) -> "Gathered":
        """Build from the ``mcc gather --json`` document."""
        cards: Dict[int, Trace] = {}
        for c in doc["cards"]:
            n = int(c["card"])
            cards[n] = Trace(
                card=n,
                cycle=_col(c["cycle"], "q"),
                commanded={int(m): _col(v, "d") for m, v in c["commanded"].items()},
                actual={int(m): _col(v, "d") for m, v in c["actual"].items()},
                cycle_ms=float(c.get("cycle_ms", 0.0)),
            )
        return cls(first_cycle=int(doc["first_cycle"]), period=int(doc["period"]),
                   motors=[int(m) for m in doc["motors"]], cards=cards)
