"""Running the ``mcc`` binary: where it is, bounded invocations, its JSON errors."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import warnings
from importlib import metadata
from pathlib import Path
from typing import Any, Dict, Mapping, Optional, Sequence

from .errors import (
    ClusterBusy,
    ClusterStartError,
    ConfigError,
    LockTimeout,
    MccError,
    MccNotFound,
)

#: Environment variables of the user's shell that would change what a test cluster does.
SCRUBBED_ENV = ("MCC_CHAIN_PTY", "MCC_CHAIN_PORT", "MCC_TEST_AT_DELAY_MS", "MCC_RUN_DIR")

#: Default bound of one CLI call, seconds (the machine may be busy).
VERB_TIMEOUT = 120.0


#: The distribution this module is installed from (the wheel carries the ``mcc`` binary).
DISTRIBUTION = "pytest-mcc"


def bundled_mcc() -> Optional[str]:
    """The ``mcc`` binary installed with this package (the wheel's, in the environment's
    scripts directory), None if the package was installed without it."""
    try:
        dist = metadata.distribution(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        return None
    for f in dist.files or ():
        # RECORD names it relative to site-packages: ``../../../bin/mcc``.
        if f.name == "mcc" and f.parent.name in ("bin", "Scripts"):
            p = Path(str(dist.locate_file(f))).resolve()
            if p.is_file() and os.access(p, os.X_OK):
                return str(p)
    return None


def find_mcc(explicit: Optional[str] = None) -> str:
    """The ``mcc`` binary: the one installed with this package (the wheel), else
    ``explicit`` (``--mcc-bin``), else ``$MCC_BIN``, else ``mcc`` on ``PATH``.

    The wheel's binary comes first so that the plugin always drives the ``mcc`` of its own
    version. The card and station roles are found by ``mcc`` itself (``$MCC_BIN_DIR``, the
    binaries next to it, else ``mcc`` runs them itself).
    """
    bundled = bundled_mcc()
    given = explicit or os.environ.get("MCC_BIN")
    if bundled:
        if given and Path(given).expanduser().resolve() != Path(bundled):
            warnings.warn(f"pytest-mcc runs the mcc binary it was installed with ({bundled}), "
                          f"not {given!r} (--mcc-bin/$MCC_BIN are for an install without it)",
                          stacklevel=2)
        return bundled
    for cand in (explicit, os.environ.get("MCC_BIN")):
        if cand:
            p = Path(cand).expanduser()
            if p.is_file() and os.access(p, os.X_OK):
                return str(p.resolve())
            raise MccNotFound(f"mcc binary {cand!r} does not exist or is not executable")
    found = shutil.which("mcc")
    if found:
        return found
    raise MccNotFound(
        "the mcc binary was not found: install the pytest-mcc wheel (pip install pytest-mcc), "
        "put mcc on PATH, set MCC_BIN=/path/to/mcc, or pass --mcc-bin to pytest"
    )


def strip_prefix(stderr: str) -> str:
    """The CLI's error message without ``mcc: error:`` (all of stderr if there is none)."""
    for line in stderr.splitlines():
        if line.startswith("mcc: error: "):
            rest = stderr[stderr.index(line) + len("mcc: error: "):]
            return rest.strip()
    return stderr.strip()


class Runner:
    """Runs ``mcc`` verbs for one cluster (``--cluster NAME``) in one run directory."""

    def __init__(self, mcc: str, run_dir: Path, cluster: str,
                 env: Optional[Mapping[str, str]] = None) -> None:
        self.mcc = mcc
        self.run_dir = run_dir
        self.cluster = cluster
        base = {k: v for k, v in os.environ.items() if k not in SCRUBBED_ENV}
        base.update(env or {})
        base["MCC_RUN_DIR"] = str(run_dir)
        self.env: Dict[str, str] = base

    def argv(self, args: Sequence[str]) -> list:
        """The full command line of ``mcc --cluster NAME args...``."""
        return [self.mcc, "--cluster", self.cluster, *args]

    def run(self, args: Sequence[str], timeout: float = VERB_TIMEOUT,
            check: bool = True) -> subprocess.CompletedProcess:
        """Run a verb; with ``check`` a non-zero exit raises :class:`MccError` with its message."""
        argv = self.argv(args)
        try:
            out = subprocess.run(argv, env=self.env, stdin=subprocess.DEVNULL,
                                 capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired as e:
            raise MccError(f"mcc {' '.join(args)} did not finish within {timeout:.0f} s",
                           stderr=_text(e.stderr), command=argv) from None
        if check and out.returncode != 0:
            raise error_from(out, argv)
        return out

    def json(self, args: Sequence[str], timeout: float = VERB_TIMEOUT) -> Any:
        """Run a ``--json`` verb and parse its stdout (errors raise, typed by their kind)."""
        out = self.run(args, timeout=timeout, check=False)
        doc = _parse(out.stdout)
        if out.returncode != 0 or (isinstance(doc, dict) and "error" in doc
                                   and isinstance(doc["error"], dict)):
            raise error_from(out, self.argv(args), doc)
        if doc is None:
            raise MccError(f"mcc {' '.join(args)} printed no JSON: {out.stdout!r}",
                           stderr=out.stderr, command=self.argv(args))
        return doc


def _text(b: Any) -> str:
    if b is None:
        return ""
    if isinstance(b, bytes):
        return b.decode("utf-8", "replace")
    return str(b)


def docs(stdout: str) -> list:
    """Every JSON document printed on ``stdout``, in order (a verb may print its result and
    then an error document)."""
    dec = json.JSONDecoder()
    out = []
    i, n = 0, len(stdout)
    while i < n:
        while i < n and stdout[i].isspace():
            i += 1
        if i >= n:
            break
        try:
            doc, i = dec.raw_decode(stdout, i)
        except ValueError:
            break
        out.append(doc)
    return out


def _parse(stdout: str) -> Any:
    """The last JSON document on ``stdout`` (None if there is none)."""
    found = docs(stdout or "")
    return found[-1] if found else None


def error_from(out: subprocess.CompletedProcess, argv: Sequence[str],
               doc: Any = None) -> MccError:
    """The typed exception for a failed verb (JSON error document when there is one)."""
    if doc is None:
        doc = _parse(out.stdout or "")
    err = doc.get("error") if isinstance(doc, dict) else None
    stderr = out.stderr or ""
    if isinstance(err, dict):
        kind = str(err.get("kind", "error"))
        message = str(err.get("message", "")) or strip_prefix(stderr)
        logs = err.get("logs") or {}
        if kind == "config":
            return ConfigError(message, stderr=stderr, command=argv)
        if kind == "running":
            return ClusterBusy(message, stderr=stderr, command=argv)
        if kind == "lock-timeout":
            return LockTimeout(message, logs=logs, kind=kind, stderr=stderr, command=argv)
        if kind in ("start", "exited"):
            return ClusterStartError(message, logs=logs, kind=kind, stderr=stderr,
                                     command=argv)
        return MccError(message, stderr=stderr, command=argv)
    message = strip_prefix(stderr) or f"mcc exited with status {out.returncode}"
    if out.returncode == 2 and ("error: invalid value" in stderr or "Usage:" in stderr):
        # clap refused an argument (e.g. --clock sometimes): a configuration the CLI refuses.
        return ConfigError(message, stderr=stderr, command=argv)
    return MccError(message, stderr=stderr, command=argv)
