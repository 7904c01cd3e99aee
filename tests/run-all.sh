#!/usr/bin/env bash
# The whole check: formatting, clippy (warnings are errors), docs, every Rust test, the
# scenario binary (in-process scenarios in parallel, multi-process clusters one at a time),
# then the Python host-client suite in a venv it creates itself. Each phase prints its time.
set -euo pipefail
cd "$(dirname "$0")/.."
export MCC_LOG="${MCC_LOG:-warn}"
phase() {
    local name="$1"
    shift
    local t0=$SECONDS
    echo "== $name"
    "$@"
    echo "== $name: $((SECONDS - t0)) s"
}
# Scenario modules that start real multi-process clusters: timing-sensitive on 2 cores, so
# they run one at a time; everything else runs in parallel.
MULTI=(axis_cli:: busy_ports:: chain:: cluster:: drills:: emcl:: gather:: host_limits:: hosts:: persistence:: power_ring:: private_run_dir:: refusals:: reliability:: stations:: testing_api::)
skips=()
for m in "${MULTI[@]}"; do skips+=(--skip "$m"); done
phase fmt cargo fmt --all -- --check
phase clippy cargo clippy --workspace --all-targets -- -D warnings
phase doc env RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps -q
phase build cargo build --workspace --bins
phase python-wheel bash python/test-wheel.sh
# Always the whole workspace (one feature set: nothing is compiled twice).
phase unit-tests cargo test --workspace --lib --bins
phase doc-tests cargo test --workspace --doc
# The ring's pure protocol alone, without its runtime feature (no zenoh, no threads): builds
# only mcc-ring and its small dependencies, never the rest of the workspace again.
phase ring-pure bash -c 'cargo build -p mcc-ring --no-default-features -q && cargo test -p mcc-ring --no-default-features --lib -q'
# Clusters on several hosts need zenohd (built once, cached in target/) and `ip` (netns).
phase hosts-prepare bash tests/hosts/prepare.sh
phase scenarios-in-process cargo test --workspace --test scenarios -- "${skips[@]}"
phase scenarios-multi-process cargo test --workspace --test scenarios -- --test-threads=1 "${MULTI[@]}"
phase host-clients bash tests/clients/run.sh
# The pytest plugin (python/) and the examples/, against real clusters (same venv).
MCC_SKIP_BUILD=1 phase python-plugin bash python/run-tests.sh
