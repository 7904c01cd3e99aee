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
if ! "$venv/bin/python" -c 'import dls_pmaclib, dls_pmacanalyse, dls_pmac_control, pmac_motorhome, pytest, pytrinamic, pyTMCL, serial' 2>/dev/null; then
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
        -r "$here/requirements.txt"
fi
# dls-pmaccontrol's Qt (PyQt5 wheels, offscreen) needs a few system libraries (GL, X11/xcb,
# fontconfig, freetype, glib) that a bare CI machine may lack: install them with apt-get, as
# root, only when Qt cannot load.
if ! QT_QPA_PLATFORM=offscreen "$venv/bin/python" -c 'from PyQt5.QtWidgets import QApplication; QApplication([])' >/dev/null 2>&1 \
    && command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
    glib=libglib2.0-0
    apt-cache show libglib2.0-0t64 >/dev/null 2>&1 && glib=libglib2.0-0t64
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        libgl1 "$glib" libfontconfig1 libfreetype6 libx11-6 libxcb1 libxext6 >/dev/null
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
