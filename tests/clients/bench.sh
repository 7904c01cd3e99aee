#!/usr/bin/env bash
# Wall-clock benchmark of the default cluster through dls-pmaclib (bench_wallclock.py):
# release binaries, the clients venv with the pytest-mcc package installed. Arguments go to
# the script (--repeat N, --cards C, --stations S, --rtf X).
# Env: MCC_BIN (default target/release/mcc), PYTHON.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="$root/target/clients-venv"
py="${PYTHON:-$(command -v python3.11 || command -v python3)}"
if [ ! -x "$venv/bin/python" ]; then
    "$py" -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    -r "$here/requirements.txt" -r "$root/python/requirements-test.txt"
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps \
    --no-build-isolation --force-reinstall "$root/python"
if [ -z "${MCC_BIN:-}" ]; then
    (cd "$root" && cargo build -q --release -p mcc-orchestrator -p mcc-card -p mcc-station)
fi
bin="${MCC_BIN:-$root/target/release/mcc}"
export MCC_BIN="$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")"
export MCC_LOG="${MCC_LOG:-warn}"
exec "$venv/bin/python" "$here/bench_wallclock.py" "$@"
