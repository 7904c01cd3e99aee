"""Axis faults of a station's plant, as ``Cluster.fault`` takes them:
``fault("station0", "axis", NODE, KIND, value=V, cycles=N)`` and
``fault("station0", "power-loss", cycles=N)`` (``mcc fault STATION axis NODE KIND`` /
``mcc fault STATION power-loss``). Every word and option is checked before anything runs,
with :class:`~pytest_mcc.errors.UnknownChoice` naming the valid ones."""

from __future__ import annotations

from typing import Any, List, Mapping, Sequence

from .errors import ConfigError, UnknownChoice

#: Axis fault kinds (``mcc fault STATION axis NODE KIND``).
AXIS_KINDS = ("amp-fault", "encoder-loss", "encoder-glitch", "load", "jam",
              "plus-limit-on", "plus-limit-off", "plus-limit-chatter",
              "minus-limit-on", "minus-limit-off", "minus-limit-chatter",
              "home-on", "home-off", "home-chatter")
#: The kinds that need ``value`` (encoder-glitch: counts, load: N·m); the others take none.
AXIS_VALUE_KINDS = ("encoder-glitch", "load")


def _station_nodes(status: Mapping[str, Any], station: str) -> List[int]:
    stations = list(status["stations"] or [])
    for s in stations:
        if s["name"] == station:
            return [int(n) for n in s["nodes"]]
    raise UnknownChoice("station", station, [s["name"] for s in stations])


def _cycles(options: Mapping[str, Any], allowed: Sequence[str], what: str) -> List[str]:
    for k in options:
        if k not in allowed:
            raise UnknownChoice(f"option of {what}", k, list(allowed))
    n = options.get("cycles")
    if n is None:
        return []
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ConfigError(f"{what}: cycles must be an integer of at least 1, got {n!r} "
                          f"(leave it out to fault until cleared)")
    return ["--cycles", str(n)]


def axis_args(status: Mapping[str, Any], station: str, words: Sequence[Any],
              options: Mapping[str, Any]) -> List[str]:
    """The ``mcc`` arguments of ``fault(station, "axis", node, kind, **options)``."""
    nodes = _station_nodes(status, station)
    if len(words) != 2:
        raise UnknownChoice("axis fault words (node, kind)", tuple(words), [])
    node, kind = words
    if isinstance(node, bool) or not isinstance(node, int) or node not in nodes:
        raise UnknownChoice(f"servo node of {station}", node, nodes)
    if kind not in AXIS_KINDS:
        raise UnknownChoice("axis fault kind", kind, AXIS_KINDS)
    allowed = ("cycles", "value") if kind in AXIS_VALUE_KINDS else ("cycles",)
    args = ["fault", station, "axis", str(node), kind] + _cycles(options, allowed,
                                                                 f"axis fault {kind!r}")
    if kind in AXIS_VALUE_KINDS:
        v = options.get("value")
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ConfigError(f"axis fault {kind!r} needs value= (encoder-glitch: counts, "
                              f"load: N·m), got {v!r}")
        args += ["--value", repr(float(v))]
    return args


def power_loss_args(status: Mapping[str, Any], station: str, words: Sequence[Any],
                    options: Mapping[str, Any]) -> List[str]:
    """The ``mcc`` arguments of ``fault(station, "power-loss", cycles=N)``."""
    _station_nodes(status, station)
    if words:
        raise UnknownChoice("word after power-loss", tuple(words), [])
    return ["fault", station, "power-loss"] + _cycles(options, ("cycles",), "power-loss")
