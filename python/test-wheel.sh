#!/usr/bin/env bash
# The wheel as a Python user gets it: build it from what `cargo build --workspace --bins`
# built (dev profile, nothing compiled again: build-wheel.sh --reuse), install it into a fresh
# venv, and run a user's pytest files (python/wheel-test) there with nothing of the workspace
# around: no cargo, no target/ directory on PATH, no MCC_BIN/MCC_BIN_DIR, run outside the
# repository. They check `pip show`, `mcc --version` against the workspace version, and run a
# cluster up, a jog, a cut and down. Env: PYTHON; arguments go to pytest.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
py="${PYTHON:-$(command -v python3.11 || command -v python3)}"
py="$("$py" -c 'import sys; print(sys.executable)')"
wheel="$(bash "$here/build-wheel.sh" --dev --reuse | tail -1)"
version="$(sed -n 's/^version = "\(.*\)"$/\1/p' "$root/Cargo.toml" | head -1)"
work="$(mktemp -d "${TMPDIR:-/tmp}/mcc-wheel-test.XXXXXX")"
trap 'rm -rf "$work"' EXIT
"$py" -m venv "$work/venv"
# The user's command, with pytest pinned for the test (the wheel asks for pytest>=7).
"$work/venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    -c "$here/requirements-wheel-test.txt" "$wheel"
cp "$here"/wheel-test/test_*.py "$work/"
cd "$work"
env -i HOME="$HOME" TMPDIR="${TMPDIR:-/tmp}" LANG=C.UTF-8 MCC_LOG="${MCC_LOG:-warn}" \
    PATH="$work/venv/bin:/usr/local/bin:/usr/bin:/bin" MCC_EXPECT_VERSION="$version" \
    pytest -q -p no:cacheprovider "$@" test_install.py test_user.py
