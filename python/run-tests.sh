#!/usr/bin/env bash
# The pytest-mcc package's own tests (python/tests) and the examples (examples/), against
# real clusters. Uses the one venv under target/ (the one tests/clients/run.sh uses),
# installs the package into it as a user would (`pip install ./python`), and runs both.
# Env: MCC_BIN (default target/debug/mcc), PYTHON, MCC_SKIP_BUILD=1 (no cargo build).
# Arguments go to both pytest runs (e.g. -x, -k name).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
venv="$root/target/clients-venv"
py="${PYTHON:-$(command -v python3.11 || command -v python3)}"
if [ ! -x "$venv/bin/python" ]; then
    "$py" -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    -r "$root/tests/clients/requirements.txt" -r "$here/requirements-test.txt"
# The package as users install it (no build isolation: flit_core is pinned above).
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps \
    --no-build-isolation --force-reinstall "$here"
if [ "${MCC_SKIP_BUILD:-0}" != "1" ] && [ -z "${MCC_BIN:-}" ]; then
    (cd "$root" && cargo build -q --workspace --bins)
fi
bin="${MCC_BIN:-$root/target/debug/mcc}"
export MCC_BIN="$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")"
export MCC_LOG="${MCC_LOG:-warn}"
cd "$here"
"$venv/bin/python" -m pytest -q -p no:cacheprovider tests "$@"
cd "$root/examples"
"$venv/bin/python" -m pytest -q -p no:cacheprovider . "$@"
