#!/usr/bin/env bash
# The pytest-mcc package's own tests (python/tests) and the examples (examples/), against
# real clusters. Uses the one venv under target/ (the one tests/clients/run.sh uses),
# installs the package into it as a user would (the wheel, with the `mcc` binary inside:
# python/build-wheel.sh --dev, from what `cargo build --workspace --bins` built), and runs
# both. Env: PYTHON, MCC_SKIP_BUILD=1 (no cargo build; the wheel of target/wheels/dev if
# there is one). Arguments go to both pytest runs (e.g. -x, -k name).
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
wheel=""
if [ "${MCC_SKIP_BUILD:-0}" != "1" ]; then
    (cd "$root" && cargo build -q --workspace --bins)
else
    wheel="$(ls "$root"/target/wheels/dev/pytest_mcc-*.whl 2>/dev/null || true)"
fi
if [ -z "$wheel" ]; then
    wheel="$(bash "$here/build-wheel.sh" --dev | tail -1)"
fi
# The package as users install it: the plugin runs the wheel's mcc.
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps \
    --force-reinstall "$wheel"
unset MCC_BIN MCC_BIN_DIR
export MCC_LOG="${MCC_LOG:-warn}"
cd "$here"
"$venv/bin/python" -m pytest -q -p no:cacheprovider tests "$@"
cd "$root/examples"
"$venv/bin/python" -m pytest -q -p no:cacheprovider . "$@"
