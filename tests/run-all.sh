#!/usr/bin/env bash
# The whole test suite: Rust unit tests, the scenario binary (in-process ring, transcripts,
# multi-process clusters), then the Python host-client suite in a venv it creates itself.
set -euo pipefail
cd "$(dirname "$0")/.."
export MCC_LOG="${MCC_LOG:-warn}"
cargo build --workspace --bins
cargo test --workspace -- --test-threads="${MCC_TEST_THREADS:-1}"
bash tests/clients/run.sh
# The pytest plugin (python/) and the examples/, against real clusters (same venv).
MCC_SKIP_BUILD=1 bash python/run-tests.sh
