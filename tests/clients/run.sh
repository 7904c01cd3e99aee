#!/usr/bin/env bash
# Runs the Python host-client tests (dls-pmaclib against a real `mcc-card --standalone`,
# its PPmacSshInterface and dls-powerpmacanalyse against Power cards;
# pytrinamic and pyTMCL against a running cluster's EMCL bus).
# Creates a venv under target/ on first use; safe to re-run. Exits non-zero on failure.
# Env: MCC_CARD_BIN (default target/debug/mcc-card), MCC_BIN (default target/debug/mcc),
#      PYTHON (default python3.11 or python3),
#      MCC_SKIP_BUILD=1 to skip `cargo build --workspace --bins`.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="$root/target/clients-venv"
py="${PYTHON:-$(command -v python3.11 || command -v python3)}"
if [ ! -x "$venv/bin/python" ]; then
    "$py" -m venv "$venv"
fi
if ! "$venv/bin/python" -c 'import dls_pmaclib, dls_pmacanalyse, pmac_motorhome, pytest, pytrinamic, pyTMCL, serial' 2>/dev/null; then
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
        -r "$here/requirements.txt"
fi
# dls-powerpmacanalyse without its GUI dependencies (see requirements-nodeps.txt).
if ! "$venv/bin/python" -c 'import dls_powerpmacanalyse, scp, numpy' 2>/dev/null; then
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps \
        -r "$here/requirements-nodeps.txt"
fi
if [ "${MCC_SKIP_BUILD:-0}" != "1" ] && [ -z "${MCC_CARD_BIN:-}" ]; then
    (cd "$root" && cargo build -q --workspace --bins)
fi
# The TMCL client tests start a cluster: mcc, mcc-card and mcc-station.
if [ "${MCC_SKIP_BUILD:-0}" != "1" ] && [ -z "${MCC_BIN:-}" ]; then
    (cd "$root" && cargo build -q --workspace --bins)
fi
export MCC_BIN="${MCC_BIN:-$root/target/debug/mcc}"
bin="${MCC_CARD_BIN:-$root/target/debug/mcc-card}"
export MCC_CARD_BIN="$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")"
cd "$here"
exec "$venv/bin/python" -m pytest -q -p no:cacheprovider "$@"
