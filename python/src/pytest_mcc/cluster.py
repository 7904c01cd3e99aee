"""A cluster under test: started with ``mcc up --detach`` in a private run directory, driven
through the ``mcc`` CLI, and always taken down again."""

from __future__ import annotations

import atexit
import inspect
import itertools
import os
import re
import shutil
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

from . import axis as axismod
from . import config as cfgmod
from ._cli import VERB_TIMEOUT, Runner, docs, find_mcc
from ._procs import Tracked
from .card import Card
from .errors import CardError, MccError, UnknownChoice, WaitTimeout
from .gather import Gathered
from .status import Status, StatusStream

#: Ring faults ``mcc fault MEMBER KIND`` injects on a member's send path.
FAULT_KINDS = ("drop-sync", "drop-packets", "corrupt", "byte-violation", "overrun",
               "underrun", "delay", "delay-us", "cut")
#: Process drills ``mcc fault MEMBER DRILL`` (SIGSTOP, SIGCONT, SIGKILL, restart).
DRILLS = ("freeze", "thaw", "kill", "restart")
#: Options of a ring fault (``mcc fault --cycles/--probability/--seed/--delay``).
FAULT_OPTIONS = ("cycles", "probability", "seed", "delay")
#: A card's hardware stop inputs ``mcc fault CARD input KIND`` (README "Card inputs").
INPUT_KINDS = ("abort", "feed-hold")
#: Options of ``mcc fault CARD input KIND`` (``--cs N`` the FPD-selected C.S., ``--cycles N``).
INPUT_OPTIONS = ("cs", "cycles")
#: Host-link faults ``mcc fault CARD|chain|bus link KIND`` (``bad-checksum``: the bus only).
#: Options: ``cycles`` (the next N replies), ``probability`` (per reply), ``seed``,
#: ``delay`` (ms, ``late`` only).
LINK_KINDS = ("no-reply", "late", "short", "stray-cr", "stray-lf", "stray-bel", "stray-ctrl",
              "corrupt", "reset", "bad-checksum")
#: Fault families with words of their own after the kind: ``fault(station, "axis", node,
#: kind)``, ``fault(station, "power-loss")``, ``fault(target, "link", kind)``,
#: ``fault(card, "input", kind)``.
FAULT_FAMILIES = ("axis", "power-loss", "link", "input")

_LIVE: Dict[int, "Cluster"] = {}
_LIVE_LOCK = threading.Lock()
_NAMES = itertools.count()


def stop_all() -> None:
    """Take down every cluster of this process that is still up (atexit, session end)."""
    with _LIVE_LOCK:
        live = list(_LIVE.values())
    for c in live:
        try:
            c.stop()
        except Exception:  # noqa: BLE001 - best effort at exit
            pass


atexit.register(stop_all)


@dataclass
class CardStart:
    """One card's part of a synchronized start."""

    card: int
    executed_cycle: Optional[int]
    reply: str
    program_start_cycle: Optional[int]
    #: The card's refusal of the line (``ERR003``, ``error #20``), whatever its reply shows.
    refusal: Optional[str] = None


@dataclass
class SyncStart:
    """A synchronized start (``mcc start-sync --json``): every card ran the line in the servo
    tick of ring cycle :attr:`cycle`."""

    cycle: int
    lead_cycles: int
    rate_hz: float
    attempts: int
    cards: List[CardStart]

    @classmethod
    def from_json(cls, doc: Mapping[str, Any]) -> "SyncStart":
        return cls(
            cycle=int(doc["cycle"]), lead_cycles=int(doc["lead_cycles"]),
            rate_hz=float(doc["rate_hz"]), attempts=int(doc["attempts"]),
            cards=[CardStart(card=int(c["card"]), executed_cycle=c.get("executed_cycle"),
                             reply=str(c.get("reply", "")),
                             program_start_cycle=c.get("program_start_cycle"),
                             refusal=c.get("refusal"))
                   for c in doc["cards"]],
        )


Predicate = Union[Callable[[], Any], Callable[[Status], Any]]


def _wants_status(pred: Callable[..., Any]) -> bool:
    try:
        params = inspect.signature(pred).parameters.values()
    except (TypeError, ValueError):
        return False
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)
                  and p.default is p.empty]
    return bool(positional) or any(p.kind == p.VAR_POSITIONAL for p in params)


class Cluster:
    """A cluster of mcc cards and stations for one test (or one module, or a script).

    Build it with the layout options (or a whole ``config``), then :meth:`start` it (or use
    it as a context manager); :meth:`stop` always takes it down: ``mcc down``, then SIGKILL of
    any process it had, then removal of its private directory. The cluster also stops by
    itself when this Python process dies (``mcc up --owner-pid``).

    :param config: a whole config instead of the default layout: TOML text, a path, or a dict
        with the README's keys (the layout options are applied on top).
    :param cards: cards in the default layout (``mcc up --cards``).
    :param stations: stations in the default layout (``mcc up --stations``).
    :param clock: ``"paced"``, ``"lockstep"`` or ``"realtime"`` (default: the config's, else
        mcc's default).
    :param rate_hz: ring rate.
    :param profiles: ``"turbo"``/``"pmac2"`` for every card, or one per card (sequence, or
        mapping by card number or name).
    :param ivars: start-up I-variables for every card (``{"I130": 3000}``) or per card.
    :param plant: station plant settings for every station (``[stations.plant]`` keys;
        ``{"nodes": {"1": {...}}}`` for one node).
    :param plants: plant settings per station name, over ``plant``.
    :param drives: ``[[drives]]`` entries (EDB step drives on the EMCL bus).
    :param extra: other top-level config keys, as given (e.g. ``{"rtf": 2.0}``).
    :param mcc: path of the ``mcc`` binary when the package carries none (the wheel's comes
        first; default ``$MCC_BIN``, else ``mcc`` on PATH).
    :param name: cluster name (default: unique per process).
    :param lock_timeout: seconds the ring has to lock (``mcc up --timeout``).
    :param env: extra environment for the cluster's processes.
    """

    def __init__(
        self,
        config: Union[None, str, os.PathLike, Mapping[str, Any]] = None,
        *,
        cards: int = 2,
        stations: int = 2,
        clock: Optional[str] = None,
        rate_hz: Optional[float] = None,
        profiles: Any = None,
        ivars: Any = None,
        plant: Optional[Mapping[str, Any]] = None,
        plants: Optional[Mapping[str, Mapping[str, Any]]] = None,
        drives: Optional[Sequence[Mapping[str, Any]]] = None,
        extra: Optional[Mapping[str, Any]] = None,
        mcc: Optional[str] = None,
        name: Optional[str] = None,
        lock_timeout: float = 120.0,
        env: Optional[Mapping[str, str]] = None,
    ) -> None:
        self.mcc = find_mcc(mcc)
        self.name = name or f"pytest-{os.getpid()}-{next(_NAMES)}"
        self.lock_timeout = float(lock_timeout)
        self._dir = Path(tempfile.mkdtemp(prefix=f"mcc-{self.name}-"))
        #: The ``MCC_RUN_DIR`` of this cluster (private to it).
        self.run_base = self._dir / "run"
        self._runner = Runner(self.mcc, self.run_base, self.name, env)
        self._options = dict(config=config, cards=cards, stations=stations, clock=clock,
                             rate_hz=rate_hz, profiles=profiles, ivars=ivars, plant=plant,
                             plants=plants, drives=drives, extra=extra)
        self._tracked = Tracked()
        self._closers: List[Callable[[], Any]] = []
        self._stream: Optional[StatusStream] = None
        self._started = False
        self._stopped = False
        #: The config the cluster runs (dict), once built.
        self.config: Dict[str, Any] = {}
        #: The status document ``mcc up`` printed once the ring locked.
        self.initial_status: Optional[Status] = None

    # -- life cycle -------------------------------------------------------------------------

    def build_config(self) -> Dict[str, Any]:
        """The config this cluster will run (checked by mcc: :class:`ConfigError` if refused)."""
        o = self._options
        base = o["config"]
        if base is None:
            out = self._runner.run(["up", "--print-config", "--cards", str(o["cards"]),
                                    "--stations", str(o["stations"])], timeout=VERB_TIMEOUT)
            doc = cfgmod.parse_toml(out.stdout)
        elif isinstance(base, Mapping):
            doc = dict(base)
        else:
            text = str(base)
            p = Path(text).expanduser() if "\n" not in text and len(text) < 4096 else None
            doc = cfgmod.parse_toml(p.read_text() if p is not None and p.is_file() else text)
        doc = cfgmod.build(doc, clock=o["clock"], rate_hz=o["rate_hz"], profiles=o["profiles"],
                           ivars=o["ivars"], plant=o["plant"], plants=o["plants"],
                           drives=o["drives"], extra=o["extra"])
        doc["cluster"] = self.name
        return doc

    def start(self) -> "Cluster":
        """Start the cluster and wait until its ring is locked (``mcc up --detach``).

        Raises :class:`ConfigError` (the config was refused, with mcc's message),
        :class:`LockTimeout` (no lock within ``lock_timeout``; member logs attached) or
        :class:`ClusterStartError`. Nothing is left running when it raises.
        """
        if self._started:
            return self
        self._started = True
        with _LIVE_LOCK:
            _LIVE[id(self)] = self
        try:
            self.config = self.build_config()
            path = self._dir / "cluster.toml"
            path.write_text(cfgmod.to_toml(self.config))
            doc = self._runner.json(
                ["up", "--detach", "--json", "--config", str(path),
                 "--timeout", str(max(1, int(round(self.lock_timeout)))),
                 "--owner-pid", str(os.getpid())],
                timeout=self.lock_timeout + 90.0)
            self.initial_status = Status(doc)
            self._remember(self.initial_status)
        except BaseException:
            self.stop()
            raise
        return self

    def stop(self) -> None:
        """Take the cluster down; idempotent, never raises for an already-dead cluster.

        ``mcc down`` first (members stopped in order), then SIGKILL for any process of the
        cluster still running, then the private directory is removed.
        """
        if self._stopped:
            return
        self._stopped = True
        try:
            for close in reversed(self._closers):
                try:
                    close()
                except Exception:  # noqa: BLE001 - a client of a dead card
                    pass
            if self._stream is not None:
                self._stream.close()
            if self._started:
                try:
                    self._runner.run(["down", "--timeout", "5"], timeout=60.0, check=False)
                except MccError:
                    pass
            self._tracked.kill_all()
        finally:
            shutil.rmtree(self._dir, ignore_errors=True)
            with _LIVE_LOCK:
                _LIVE.pop(id(self), None)

    def __enter__(self) -> "Cluster":
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.stop()

    @property
    def running(self) -> bool:
        """Started and not stopped."""
        return self._started and not self._stopped

    def _remember(self, st: Status) -> None:
        self._tracked.add(m.get("pid") for m in st["members"])
        self._tracked.add([st["supervisor"].get("pid")])

    def _need_running(self) -> None:
        if not self.running:
            raise MccError(f"cluster {self.name} is not running (start() it first)")

    # -- looking ----------------------------------------------------------------------------

    @property
    def members(self) -> List[str]:
        """Member names in ring order."""
        self._need_running()
        assert self.initial_status is not None
        return self.initial_status.member_names

    @property
    def card_numbers(self) -> List[int]:
        """Card numbers (I0) in config order."""
        self._need_running()
        assert self.initial_status is not None
        return [c["number"] for c in self.initial_status["cards"]]

    def status(self) -> Status:
        """``mcc status --json`` now."""
        self._need_running()
        st = Status(self._runner.json(["status", "--json"]))
        self._remember(st)
        return st

    def card(self, number: int) -> Card:
        """Card ``number`` (I0): its ports, commands, a dls-pmaclib client."""
        self._need_running()
        if number not in self.card_numbers:
            raise UnknownChoice("card", number, self.card_numbers)
        return Card(self, number)

    def log(self, member: str, lines: Optional[int] = None) -> str:
        """The log of ``member`` (or ``supervisor``), the last ``lines`` lines if given."""
        if member not in self.members + ["supervisor"]:
            raise UnknownChoice("member", member, self.members + ["supervisor"])
        path = self.run_base / self.name / "logs" / f"{member}.log"
        try:
            text = path.read_text(errors="replace")
        except OSError:
            return ""
        return text if lines is None else "\n".join(text.splitlines()[-lines:])

    def logs(self, lines: int = 40) -> Dict[str, str]:
        """The last ``lines`` lines of every log, by member (and ``supervisor``)."""
        return {m: self.log(m, lines) for m in ["supervisor"] + self.members}

    # -- commands ---------------------------------------------------------------------------

    def send(self, line: Union[str, Sequence[str]], card: Optional[int] = None, *,
             check: bool = True, timeout_ms: Optional[int] = None) -> Any:
        """Send command line(s) on the daisy chain (``mcc send``), ``@card`` first if given.

        Returns the reply text (a list of them for a list of lines), without framing and the
        final line break. With ``check`` (default) an error reply raises :class:`CardError`
        (``.code`` is ``ERRnnn``) and a line no card answered (the addressed card is not in
        the cluster, or did not answer in time) raises :class:`MccError`. A line the card
        answers with nothing (``$$$``, ``$$$***``) returns ``""``.
        """
        self._need_running()
        lines = [line] if isinstance(line, str) else list(line)
        if not lines:
            return []
        if card is not None and card not in self.card_numbers:
            raise UnknownChoice("card", card, self.card_numbers)
        args = ["send", "--json"]
        if card is not None:
            args += ["--card", str(card)]
        if timeout_ms is not None:
            args += ["--timeout-ms", str(int(timeout_ms))]
        replies = self._runner.json(args + ["--", *lines])
        out = []
        for r in replies:
            text = str(r.get("reply", "")).rstrip("\n")
            if check and r.get("error"):
                raise CardError(r["line"], r["error"], text, card)
            if check and not r.get("answered", True):
                raise MccError(f"no card answered {r['line']!r}")
            out.append(text)
        return out[0] if isinstance(line, str) else out

    def start_sync(self, line: str, cards: Optional[Iterable[int]] = None, *,
                   lead_ms: Optional[float] = None, check: bool = True) -> SyncStart:
        """Run ``line`` on several cards (default: all) in the servo tick of the same ring
        cycle (``mcc start-sync``). With ``check``, a card refusing the line raises
        :class:`CardError` (``.detail`` holds the :class:`SyncStart`)."""
        self._need_running()
        numbers = list(self.card_numbers if cards is None else cards)
        for n in numbers:
            if n not in self.card_numbers:
                raise UnknownChoice("card", n, self.card_numbers)
        args = ["start-sync", "--json", "--cards", ",".join(str(n) for n in numbers)]
        if lead_ms is not None:
            args += ["--lead-ms", str(float(lead_ms))]
        out = self._runner.run(args + ["--", line], check=False)
        found = [d for d in docs(out.stdout) if isinstance(d, dict) and "cycle" in d]
        if not found:
            from ._cli import error_from
            raise error_from(out, self._runner.argv(args))
        result = SyncStart.from_json(found[0])
        if check:
            for c in result.cards:
                if c.refusal is not None:
                    raise CardError(line, c.refusal, c.reply, c.card, detail=result)
        return result

    def _gather_args(self, motors: Iterable[int], cards: Iterable[int], cycles: int,
                     period: int) -> List[str]:
        self._need_running()
        numbers = list(cards)
        for n in numbers:
            if n not in self.card_numbers:
                raise UnknownChoice("card", n, self.card_numbers)
        return ["gather", "--json", "--card", ",".join(map(str, numbers)),
                "--motors", ",".join(str(int(m)) for m in motors),
                "--cycles", str(int(cycles)), "--period", str(int(period))]

    def gather(self, motors: Iterable[int] = (1,), cards: Iterable[int] = (0,), *,
               cycles: int = 1000, period: int = 1, run: Optional[str] = None) -> Gathered:
        """Record commanded and actual positions of ``motors`` on ``cards`` with the cards'
        data gathering for ``cycles`` servo cycles (one sample every ``period``); gathering
        starts in the same ring cycle on every card, and ``run`` (e.g. ``"&1B1R"``) runs in
        that same tick. Returns arrays stamped with ring cycles."""
        args = self._gather_args(motors, cards, cycles, period)
        if run is not None:
            args += ["--run", run]
        doc = self._runner.json(args, timeout=VERB_TIMEOUT + cycles / 100.0)
        return Gathered.from_json(doc)

    def gathering(self, motors: Iterable[int] = (1,), cards: Iterable[int] = (0,), *,
                  cycles: int = 1000, period: int = 1, timeout: float = 60.0) -> "Recording":
        """Like :meth:`gather`, but in the background while the ``with`` body runs your own
        code (which starts the motion)::

            with cluster.gathering(motors=[1], cards=[0, 1], cycles=2000) as rec:
                my_scan.start()
            data = rec.result()

        Entering returns once gathering runs (from ring cycle ``rec.first_cycle``)."""
        args = self._gather_args(motors, cards, cycles, period)
        return Recording(self, self._runner.argv(args), timeout, cycles)

    @property
    def daisy_chain(self) -> Tuple[str, int]:
        """Host and TCP port of the daisy chain (the serial multi-drop line, ``@n``
        addressing), as a terminal server would offer it."""
        self._need_running()
        assert self.initial_status is not None
        host, port = str(self.initial_status["daisy_chain"]).rsplit(":", 1)
        return host, int(port)

    # -- faults -----------------------------------------------------------------------------

    def _check_member(self, member: str) -> None:
        if member not in self.members:
            raise UnknownChoice("member", member, self.members)

    def fault(self, member: str, kind: str, *words: Any, **options: Any) -> str:
        """Inject ring fault ``kind`` on ``member``'s send path, or run a process drill
        (``mcc fault MEMBER KIND``), or an application fault (the CLI's words after
        ``mcc fault``).

        Kinds: :data:`FAULT_KINDS` (options ``cycles``, ``probability``, ``seed``, ``delay``)
        and :data:`DRILLS` (no options); ``fault(station, "axis", node, kind, value=V,
        cycles=N)`` with a kind of :data:`~pytest_mcc.axis.AXIS_KINDS` and
        ``fault(station, "power-loss", cycles=N)``. An unknown member, kind or option raises
        :class:`UnknownChoice` at once, naming the valid ones. Returns mcc's message.
        """
        self._need_running()
        if kind == "input":
            return self._fault_input(member, words, options)
        if kind == "link":
            return self._link_fault(member, words, options)
        self._check_member(member)
        if kind in ("axis", "power-loss"):
            return self._axis_fault(member, kind, words, options)
        if words:
            raise UnknownChoice(f"word after fault kind {kind!r}", words[0], [])
        if kind not in FAULT_KINDS + DRILLS:
            raise UnknownChoice("fault kind", kind, FAULT_KINDS + DRILLS + FAULT_FAMILIES)
        allowed = () if kind in DRILLS else FAULT_OPTIONS
        for k in options:
            if k not in allowed:
                raise UnknownChoice(f"option of fault {kind!r}", k, allowed)
        args = ["fault", member, kind]
        for k in FAULT_OPTIONS:
            if options.get(k) is not None:
                args += [f"--{k}", str(options[k])]
        out = self._runner.run(args).stdout.strip()
        if kind == "restart":
            self._remember_later()
        return out

    def _link_fault(self, target: str, words: Sequence[Any], options: Dict[str, Any]) -> str:
        """``fault(TARGET, "link", KIND, **options)``: a host-link fault on a card's ports,
        the daisy chain or the EMCL bus (:data:`LINK_KINDS`), checked at once."""
        assert self.initial_status is not None
        targets = [c["name"] for c in self.initial_status["cards"]] + ["chain", "bus"]
        if target not in targets:
            raise UnknownChoice("link target", target, targets)
        if len(words) != 1 or words[0] not in LINK_KINDS:
            raise UnknownChoice("link fault kind", words[0] if words else None, LINK_KINDS)
        kind = str(words[0])
        if kind == "bad-checksum" and target != "bus":
            raise UnknownChoice(f"link fault kind on {target} (bad-checksum: the EMCL bus only)",
                                kind, [k for k in LINK_KINDS if k != "bad-checksum"])
        for k in options:
            if k not in FAULT_OPTIONS:
                raise UnknownChoice(f"option of link fault {kind!r}", k, FAULT_OPTIONS)
        args = ["fault", target, "link", kind]
        for k in FAULT_OPTIONS:
            if options.get(k) is not None:
                args += [f"--{k}", str(options[k])]
        return self._runner.run(args).stdout.strip()

    def _axis_fault(self, station: str, kind: str, words: Sequence[Any],
                    options: Mapping[str, Any]) -> str:
        assert self.initial_status is not None
        build = axismod.axis_args if kind == "axis" else axismod.power_loss_args
        args = build(self.initial_status, station, words, options)
        return self._runner.run(args).stdout.strip()

    def _fault_input(self, card: str, words: Sequence[Any], options: Dict[str, Any]) -> str:
        """``fault(CARD, "input", KIND, cs=N, cycles=N)``: hold a card's stop input active
        (:data:`INPUT_KINDS`) until :meth:`clear`, or for ``cycles`` ring cycles."""
        assert self.initial_status is not None
        cards = [c["name"] for c in self.initial_status["cards"]]
        if card not in cards:
            raise UnknownChoice("card", card, cards)
        if len(words) != 1 or words[0] not in INPUT_KINDS:
            raise UnknownChoice("card input", words[0] if words else None, INPUT_KINDS)
        for k in options:
            if k not in INPUT_OPTIONS:
                raise UnknownChoice("option of fault 'input'", k, INPUT_OPTIONS)
        args = ["fault", card, "input", str(words[0])]
        for k in INPUT_OPTIONS:
            if options.get(k) is not None:
                args += [f"--{k}", str(options[k])]
        return self._runner.run(args).stdout.strip()

    def _remember_later(self) -> None:
        try:
            self._remember(self.status())
        except MccError:
            pass

    def clear(self, member: Optional[str] = None) -> str:
        """Remove injected ring faults (``mcc fault clear [MEMBER]``); the ring re-locks."""
        self._need_running()
        args = ["fault", "clear"]
        if member is not None:
            self._check_member(member)
            args.append(member)
        return self._runner.run(args).stdout.strip()

    def reset(self, member: Optional[str] = None, *, cycles: Optional[int] = None,
              timeout: float = 120.0) -> Status:
        """Recover from a ring fault as a PMAC user does: ``$$$`` on the cards (unsaved card
        settings are lost, as on a PMAC: ``SAVE`` first), then each member's ring-fault latch
        (``mcc fault reset``), repeated until the ring is locked and healthy.

        With ``member``, only that member (a card also gets its ``$$$``). Returns the first
        healthy status; :class:`WaitTimeout` if the ring stays faulted (a fault still
        injected, a member still frozen)."""
        self._need_running()
        if member is not None:
            self._check_member(member)
        assert self.initial_status is not None
        names = {c["name"]: c["number"] for c in self.initial_status["cards"]}
        targets = [member] if member is not None else self.members
        # The ring must carry frames again (every member alive and locked) before the resets
        # can hold: a latch stays set while the ring is unhealthy.
        self.wait_until(lambda st: all(st.member(m)["alive"] and st.member(m)["locked"]
                                       for m in self.members), cycles=cycles, timeout=timeout)
        for n in targets:
            if n in names:
                self.send("$$$", card=names[n])
        extra = [member] if member is not None else []
        cards = {n: names[n] for n in targets if n in names}
        sent = {n: time.monotonic() for n in cards}

        def healthy(st: Status) -> bool:
            rows = [st.member(m) for m in targets]
            if member is None:
                ok = st.locked and not st.faulted
            else:
                ok = all(r["alive"] and r["locked"] and not r["ring_fault"] for r in rows)
            if not ok:
                self._runner.run(["fault", "reset", *extra], check=False)
            # A card's own ring-fault bit must read clear too; one whose bit stays set (its
            # `$$$` lost, or latched again while the ring came back) gets `$$$` again, at most
            # once a second. An unknown bit (the card's info went unanswered) is not healthy.
            rows_by_number = {c["number"]: c for c in st.get("cards", [])}
            clear = True
            for name, number in cards.items():
                bit = rows_by_number.get(number, {}).get("ring_fault")
                if bit is not False:
                    clear = False
                if bit is True and ok and time.monotonic() - sent[name] >= 1.0:
                    self.send("$$$", card=number)
                    sent[name] = time.monotonic()
            return ok and clear

        return self.wait_until(healthy, cycles=cycles, timeout=timeout)

    # -- waiting ----------------------------------------------------------------------------

    def _status_stream(self) -> StatusStream:
        if self._stream is None or not self._stream.alive:
            if self._stream is not None:
                self._stream.close()
            self._stream = StatusStream(self._runner.argv(["status", "--json", "--watch", "50"]),
                                        self._runner.env)
        return self._stream

    def wait_until(self, predicate: Predicate, cycles: Optional[int] = None, *,
                   since: Optional[int] = None, timeout: float = 120.0) -> Status:
        """Wait until ``predicate`` holds, counting ring cycles.

        ``predicate`` takes the current :class:`Status` (or nothing). Gives up with
        :class:`WaitTimeout` once the ring has run ``cycles`` cycles (counted from ``since``,
        a ring cycle, else from the first status seen) with the predicate still false, or
        after ``timeout`` seconds of wall time (a generous bound for a ring that stopped).

        Returns a status taken once the predicate held: for a status predicate the very
        document it held on; for a plain one the next document, so ``status.cycle`` is a
        ring cycle by which the predicate held (statuses come every ~50 ms).
        """
        self._need_running()
        with_status = _wants_status(predicate)
        stream = self._status_stream()
        deadline = time.monotonic() + timeout
        st = stream.next(timeout)
        start = st.cycle if since is None else int(since)
        while True:
            self._remember(st)
            held = predicate(st) if with_status else predicate()  # type: ignore[call-arg]
            if held:
                if with_status:
                    return st
                return stream.next(max(1.0, deadline - time.monotonic()))
            if cycles is not None and st.cycle - start >= cycles:
                raise WaitTimeout(
                    f"the condition did not hold within {cycles} ring cycles "
                    f"(from cycle {start} to {st.cycle})", st)
            left = deadline - time.monotonic()
            try:
                if left <= 0:
                    raise TimeoutError
                st = stream.next(left)
            except TimeoutError:
                raise WaitTimeout(
                    f"the condition did not hold within {timeout:.0f} s "
                    f"(ring cycle {start} to {st.cycle})", st) from None

    def wait_cycles(self, cycles: int, timeout: float = 120.0) -> Status:
        """Let the ring run ``cycles`` more cycles; the status once it has."""
        first = self._status_stream().next(timeout)
        target = first.cycle + int(cycles)
        return self.wait_until(lambda st: st.cycle >= target, timeout=timeout)


class Recording:
    """A background ``mcc gather`` (see :meth:`Cluster.gathering`)."""

    def __init__(self, cluster: Cluster, argv: List[str], timeout: float, cycles: int) -> None:
        self._cluster = cluster
        self._argv = argv
        self._timeout = timeout
        self._cycles = cycles
        self._proc: Optional[subprocess.Popen] = None
        self._err: List[str] = []
        self._result: Optional[Gathered] = None
        #: Ring cycle of the first sample.
        self.first_cycle: Optional[int] = None

    def __enter__(self) -> "Recording":
        self._proc = subprocess.Popen(self._argv, env=self._cluster._runner.env,
                                      stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                      stderr=subprocess.PIPE, text=True)
        self._cluster._closers.append(self._kill)
        assert self._proc.stderr is not None
        deadline = time.monotonic() + self._timeout
        for line in self._proc.stderr:
            self._err.append(line)
            m = re.search(r"gathering from ring cycle (\d+)", line)
            if m:
                self.first_cycle = int(m.group(1))
                break
            if time.monotonic() > deadline:
                break
        if self.first_cycle is None:
            self._kill()
            raise MccError("mcc gather did not start: " + "".join(self._err).strip(),
                           stderr="".join(self._err), command=self._argv)
        return self

    def __exit__(self, *exc: Any) -> None:
        if exc and exc[0] is not None:
            self._kill()
            return
        self.result()

    def _kill(self) -> None:
        if self._proc is not None and self._proc.poll() is None:
            self._proc.kill()
            self._proc.wait()

    def result(self) -> Gathered:
        """Wait for the recording to finish; its data."""
        if self._result is not None:
            return self._result
        assert self._proc is not None
        try:
            out, err = self._proc.communicate(timeout=VERB_TIMEOUT + self._cycles / 100.0)
        except subprocess.TimeoutExpired:
            self._kill()
            raise MccError("mcc gather did not finish in time", command=self._argv) from None
        self._err.append(err)
        found = [d for d in docs(out) if isinstance(d, dict)]
        if self._proc.returncode != 0 or not found or "error" in found[-1]:
            from ._cli import error_from
            cp = subprocess.CompletedProcess(self._argv, self._proc.returncode or 1, out,
                                             "".join(self._err))
            raise error_from(cp, self._argv)
        self._result = Gathered.from_json(found[0])
        return self._result
