"""Cluster configurations: the TOML document ``mcc up --config`` reads (keys in the README's
"Cluster configuration" section), built from a few keyword arguments.

The layout starts from ``mcc``'s own embedded default (``mcc up --print-config --cards N
--stations M``), so a factory cluster with no options is exactly the cluster ``mcc up`` runs;
options then change cards, stations, plants, drives and top-level keys. ``mcc`` checks the
result (:class:`~pytest_mcc.errors.ConfigError` carries its message).
"""

from __future__ import annotations

import copy
import json
import math
import re
import sys
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on older interpreters only
    import tomli as tomllib

#: Clock modes ``mcc`` accepts (``paced`` once the paced clock is in the binary).
CLOCKS = ("paced", "lockstep", "realtime")

Doc = Dict[str, Any]

#: The ring-check start-up I-variables of mcc's embedded default (PMAC2 numbering).
PMAC2_RING_CHECK = {"I1001": 16, "I1004": 2, "I1005": 4}
PerCard = Union[None, Any, Sequence[Any], Mapping[Union[int, str], Any]]


def parse_toml(text: str) -> Doc:
    """A TOML document as a dict."""
    return tomllib.loads(text)


_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: Any) -> str:
    k = str(k)
    return k if _BARE.match(k) else json.dumps(k)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }" \
            if v else "{}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if hasattr(v, "__fspath__"):
        return json.dumps(str(v))
    raise TypeError(f"cannot write {type(v).__name__} value {v!r} to TOML")


def _is_table_array(v: Any) -> bool:
    return isinstance(v, (list, tuple)) and bool(v) and all(isinstance(x, Mapping) for x in v)


def to_toml(doc: Mapping[str, Any]) -> str:
    """Write a config dict as TOML: top-level values, then ``[table]``s, then
    ``[[array]]``s of tables (nested tables inside them written inline)."""
    lines: List[str] = []
    tables = []
    arrays = []
    for k, v in doc.items():
        if isinstance(v, Mapping):
            tables.append((k, v))
        elif _is_table_array(v):
            arrays.append((k, v))
        else:
            lines.append(f"{_key(k)} = {_value(v)}")
    for k, v in tables:
        lines.append("")
        lines.append(f"[{_key(k)}]")
        lines.extend(f"{_key(a)} = {_value(b)}" for a, b in v.items())
    for k, items in arrays:
        for item in items:
            lines.append("")
            lines.append(f"[[{_key(k)}]]")
            lines.extend(f"{_key(a)} = {_value(b)}" for a, b in item.items())
    return "\n".join(lines) + "\n"


def _per_card(value: PerCard, cards: List[Doc], what: str) -> List[Any]:
    """One value per card: a single value for all, a sequence in card order, or a mapping
    by card number or name (missing cards: None)."""
    if value is None:
        return [None] * len(cards)
    if isinstance(value, Mapping) and not _looks_like_settings(value):
        out = []
        for c in cards:
            out.append(value.get(c["number"], value.get(str(c["number"]), value.get(c["name"]))))
        known = {c["number"] for c in cards} | {str(c["number"]) for c in cards} \
            | {c["name"] for c in cards}
        unknown = [k for k in value if k not in known]
        if unknown:
            from .errors import UnknownChoice
            raise UnknownChoice(f"card in {what}", unknown[0],
                                [c["number"] for c in cards] + [c["name"] for c in cards])
        return out
    if isinstance(value, (list, tuple)):
        if len(value) != len(cards):
            raise ValueError(f"{what}: {len(value)} values for {len(cards)} cards")
        return list(value)
    return [value] * len(cards)


def _looks_like_settings(m: Mapping) -> bool:
    """An ivars-style mapping (``{"I130": 2000}``) rather than one keyed by card."""
    return any(isinstance(k, str) and k[:1] in ("I", "i") and k[1:].isdigit() for k in m)


def build(
    base: Doc,
    *,
    clock: Optional[str] = None,
    rate_hz: Optional[float] = None,
    profiles: PerCard = None,
    ivars: PerCard = None,
    plant: Optional[Mapping[str, Any]] = None,
    plants: Optional[Mapping[str, Mapping[str, Any]]] = None,
    drives: Optional[Sequence[Mapping[str, Any]]] = None,
    extra: Optional[Mapping[str, Any]] = None,
) -> Doc:
    """Apply the factory options to a resolved config ``base`` (not modified).

    - ``profiles``: ``"turbo"`` for every card, or one per card (sequence, or mapping by card
      number or name).
    - ``ivars``: start-up I-variables merged over each card's own (``{"I130": 3000}`` for every
      card, or per card as above).
    - ``plant``: ``[stations.plant]`` keys for every station (``{"nodes": {"1": {...}}}`` for
      per-node overrides); ``plants``: the same per station name (merged over ``plant``).
    - ``drives``: ``[[drives]]`` entries (EDB step drives: ``name``, ``address``, ``station``),
      replacing the layout's (the embedded default has ``drive0`` on station0).
    - ``extra``: any other top-level keys (e.g. ``{"rtf": 2.0}``), written as given.
    """
    doc = copy.deepcopy(dict(base))
    cards: List[Doc] = doc.setdefault("cards", [])
    stations: List[Doc] = doc.setdefault("stations", [])
    if clock is not None:
        doc["clock"] = clock
    if rate_hz is not None:
        doc["rate_hz"] = float(rate_hz)
    for c, p in zip(cards, _per_card(profiles, cards, "profiles")):
        if p is not None:
            c["profile"] = p
            if p != "pmac2":
                # The embedded default arms the PMAC2 ring check (I1001/I1004/I1005); a Turbo
                # card refuses those numbers (its ring check has other variables), so a card
                # switched to another profile starts without them, as a card from a file does.
                iv = c.get("ivars") or {}
                if {str(k).upper(): v for k, v in iv.items()} == PMAC2_RING_CHECK:
                    c["ivars"] = {}
    for c, iv in zip(cards, _per_card(ivars, cards, "ivars")):
        if iv:
            merged = dict(c.get("ivars") or {})
            for k, v in iv.items():
                # One spelling per variable: the caller's replaces the default's.
                for old in [o for o in merged if o.upper() == str(k).upper()]:
                    del merged[old]
                merged[str(k)] = v
            c["ivars"] = merged
    names = [s["name"] for s in stations]
    if plants:
        from .errors import UnknownChoice
        for n in plants:
            if n not in names:
                raise UnknownChoice("station in plants", n, names)
    for s in stations:
        table: Dict[str, Any] = copy.deepcopy(dict(s.get("plant") or {}))
        for layer in (plant, (plants or {}).get(s["name"])):
            if layer:
                _merge(table, layer)
        if table:
            s["plant"] = table
    if drives is not None:
        doc["drives"] = [dict(d) for d in drives]
    for k, v in (extra or {}).items():
        doc[k] = v
    return doc


def _merge(dst: Dict[str, Any], src: Mapping[str, Any]) -> None:
    for k, v in src.items():
        k = str(k)
        if isinstance(v, Mapping) and isinstance(dst.get(k), dict):
            _merge(dst[k], v)
        elif isinstance(v, Mapping):
            dst[k] = {}
            _merge(dst[k], v)
        else:
            dst[k] = v
