#!/usr/bin/env bash
# Build the pytest-mcc wheel: the plugin (python/src) and the `mcc` binary, which runs the
# card and station roles itself (`mcc run-card`, `mcc run-station`), so it is the only binary
# in the wheel. maturin (python/requirements-build.txt) runs in target/wheel-build-venv.
#
#   python/build-wheel.sh [--release | --dev] [--reuse]
#
#   --release  (default) optimised and stripped: the wheel to hand to users (a release build
#              of the whole dependency graph the first time).
#   --dev      the dev profile: the `mcc` that `cargo build --workspace --bins` built is packed
#              as it is (what the test command does).
#   --reuse    the workspace is built already: fail if cargo compiles anything (the test
#              command builds the dependency graph once).
#
# The wheel goes to target/wheels/<profile>/; its path is the last line on stdout.
# Env: PYTHON (the interpreter for the build venv).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
profile=release
reuse=0
for a in "$@"; do
    case "$a" in
        --release) profile=release ;;
        --dev) profile=dev ;;
        --reuse) reuse=1 ;;
        *) echo "build-wheel.sh: unknown option $a (--release, --dev, --reuse)" >&2; exit 2 ;;
    esac
done
venv="$root/target/wheel-build-venv"
py="${PYTHON:-$(command -v python3.11 || command -v python3)}"
if [ ! -x "$venv/bin/python" ]; then
    "$py" -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$here/requirements-build.txt"
out="$root/target/wheels/$profile"
mkdir -p "$out"
rm -f "$out"/pytest_mcc-*.whl
if [ "$profile" = release ]; then
    # --strip adds a link argument to the final binary only: the dependencies are built once.
    args=(--release --strip)
else
    # No --strip: any extra rustc argument would rebuild the orchestrator crate.
    args=(--profile dev)
fi
log="$out/build.log"
# --auditwheel check: fail rather than copy a shared library into the wheel (mcc links only
# glibc and libgcc_s); the platform tag is the lowest manylinux one the binary's symbol
# versions allow.
(cd "$here" && "$venv/bin/maturin" build "${args[@]}" --auditwheel check --out "$out") 2>&1 \
    | tee "$log" >&2
if [ "$reuse" = 1 ] && grep -E '^\s*Compiling ' "$log" >&2; then
    echo "build-wheel.sh: --reuse: cargo compiled the crates above again (the wheel must pack" \
        "what \`cargo build --workspace --bins\` built)" >&2
    exit 1
fi
wheel=$(ls "$out"/pytest_mcc-*.whl)
echo "build-wheel.sh: $(du -h "$wheel" | cut -f1) $wheel" >&2
echo "$wheel"
