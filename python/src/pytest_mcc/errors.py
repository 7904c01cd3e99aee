"""Exceptions raised by :mod:`pytest_mcc`.

Every exception carries the ``mcc`` CLI's own message (what a user would see in a shell), so a
failing test says what the cluster said.
"""

from __future__ import annotations

from typing import Any, Mapping, Optional, Sequence


class MccError(Exception):
    """Base class: something the ``mcc`` CLI or the cluster refused or could not do."""

    def __init__(self, message: str, *, stderr: str = "", command: Sequence[str] = ()) -> None:
        super().__init__(message)
        #: The CLI's message (``mcc: error: ...`` without the prefix).
        self.message = message
        #: Everything the CLI printed on stderr.
        self.stderr = stderr
        #: The ``mcc`` command line that failed.
        self.command = list(command)


class MccNotFound(MccError):
    """The ``mcc`` binary could not be found (install the wheel, or set ``MCC_BIN`` or
    ``--mcc-bin``)."""


class ConfigError(MccError, ValueError):
    """The cluster refused its configuration (bad key, value or layout), before anything ran."""


class ClusterStartError(MccError):
    """The cluster did not come up: a member exited, or the ring did not lock.

    :attr:`logs` maps ``supervisor`` and each member name to the last lines of its log.
    """

    def __init__(
        self,
        message: str,
        *,
        logs: Optional[Mapping[str, str]] = None,
        kind: str = "start",
        stderr: str = "",
        command: Sequence[str] = (),
    ) -> None:
        self.logs = dict(logs or {})
        self.kind = kind
        text = message
        for who, tail in self.logs.items():
            text += f"\n--- last lines of {who}.log ---\n{tail}"
        super().__init__(text, stderr=stderr, command=command)
        self.message = message


class LockTimeout(ClusterStartError):
    """The ring did not lock within the stated time (member logs attached in :attr:`logs`)."""


class ClusterBusy(MccError):
    """A cluster of that name already runs in this run directory."""


class CardError(MccError):
    """A card answered a command line with an error (``ERRnnn``, or a bare BELL)."""

    def __init__(self, line: str, code: str, reply: str = "", card: Optional[int] = None,
                 detail: Any = None) -> None:
        where = f"card {card}" if card is not None else "the addressed card"
        super().__init__(f"{where} refused {line!r}: {code}")
        #: The command line.
        self.line = line
        #: ``ERR003`` etc., or ``BELL``.
        self.code = code
        #: The reply as text.
        self.reply = reply
        #: Card number, when the line was addressed to one.
        self.card = card
        #: Extra data (e.g. the synchronized-start outcome).
        self.detail = detail


class UnknownChoice(MccError, ValueError):
    """A fault kind, member, card or option that does not exist; :attr:`choices` lists the
    valid ones."""

    def __init__(self, what: str, value: Any, choices: Sequence[Any]) -> None:
        self.what = what
        self.value = value
        self.choices = list(choices)
        shown = ", ".join(str(c) for c in self.choices)
        super().__init__(f"unknown {what} {value!r} (valid: {shown})")


class WaitTimeout(AssertionError):
    """:meth:`Cluster.wait_until` gave up: the ring ran the stated cycles (or the wall-clock
    bound passed) without the condition holding. :attr:`status` is the last status seen."""

    def __init__(self, message: str, status: Any = None) -> None:
        # The last status, in one line, so that a failure in CI says what the ring showed.
        summary = getattr(status, "summary", None)
        if callable(summary):
            try:
                message = f"{message}; last status: {summary()}"
            except Exception:  # noqa: BLE001 - a partial document must not hide the timeout
                pass
        super().__init__(message)
        self.status = status
