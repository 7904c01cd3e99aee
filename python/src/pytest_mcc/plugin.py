"""The pytest plugin (registered through the ``pytest11`` entry point).

Fixtures:

- ``mcc_cluster``: a started cluster for the test (the default layout: 2 cards, 2 stations),
  customised with ``@pytest.mark.mcc(**options)`` (the :class:`~pytest_mcc.Cluster` options).
- ``mcc_cluster_factory``: ``factory(**options)`` starts as many clusters as a test needs.

Every cluster is taken down when its test ends (passed, failed or interrupted); a test that
failed gets the last lines of every member's log in its report. The ``mcc`` binary: the one
the wheel installed, else ``--mcc-bin PATH``, else ``$MCC_BIN``, else ``mcc`` on PATH. Ini
keys ``mcc_clock`` (default clock of the fixtures' clusters, e.g. ``lockstep``) and
``mcc_lock_timeout`` (seconds).
"""

from __future__ import annotations

from typing import Any, Callable, Dict, Iterator, List

import pytest

from .cluster import Cluster, stop_all


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("mcc", "mcc cluster under test")
    group.addoption("--mcc-bin", action="store", default=None, metavar="PATH",
                    help="the mcc binary when the package carries none (default: $MCC_BIN, "
                    "else mcc on PATH)")
    parser.addini("mcc_clock", "default clock of mcc fixture clusters (paced, lockstep, "
                  "realtime; empty: mcc's default)", default="")
    parser.addini("mcc_lock_timeout", "seconds an mcc fixture cluster has to lock",
                  default="120")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "mcc(**options): options of the mcc_cluster fixture's cluster "
        "(cards, stations, clock, profiles, ivars, plant, plants, drives, config, ...)")


def pytest_unconfigure(config: pytest.Config) -> None:
    # Whatever a fixture could not tear down (an interrupted session) goes now.
    stop_all()


@pytest.hookimpl(hookwrapper=True, tryfirst=True)
def pytest_runtest_makereport(item: pytest.Item, call: Any) -> Iterator[Any]:
    outcome: Any = yield
    rep = outcome.get_result()
    if rep.failed and rep.when in ("setup", "call"):
        # A failed test shows what its clusters' members said (read before teardown).
        for c in getattr(item, "_mcc_clusters", []):
            if c.running:
                try:
                    text = "\n".join(f"--- {who} ---\n{tail}"
                                     for who, tail in c.logs().items() if tail)
                except Exception:  # noqa: BLE001 - logs are a courtesy
                    continue
                rep.sections.append((f"mcc logs ({c.name})", text))


def _defaults(config: pytest.Config) -> Dict[str, Any]:
    d: Dict[str, Any] = {"mcc": config.getoption("--mcc-bin")}
    clock = str(config.getini("mcc_clock") or "").strip()
    if clock:
        d["clock"] = clock
    d["lock_timeout"] = float(config.getini("mcc_lock_timeout"))
    return d


@pytest.fixture
def mcc_cluster_factory(request: pytest.FixtureRequest) -> Iterator[Callable[..., Cluster]]:
    """``factory(**options) -> Cluster``: start a cluster (see :class:`pytest_mcc.Cluster`
    for the options); every cluster it started is taken down at the end of the test."""
    started: List[Cluster] = []
    setattr(request.node, "_mcc_clusters", started)
    defaults = _defaults(request.config)

    def factory(**options: Any) -> Cluster:
        merged = {**defaults, **options}
        c = Cluster(**merged)
        started.append(c)
        return c.start()

    try:
        yield factory
    finally:
        for c in reversed(started):
            c.stop()


@pytest.fixture
def mcc_cluster(request: pytest.FixtureRequest,
                mcc_cluster_factory: Callable[..., Cluster]) -> Cluster:
    """A started cluster for this test; options from ``@pytest.mark.mcc(...)``."""
    options: Dict[str, Any] = {}
    for mark in reversed(list(request.node.iter_markers("mcc"))):
        options.update(mark.kwargs)
    return mcc_cluster_factory(**options)
