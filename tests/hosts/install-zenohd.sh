#!/usr/bin/env bash
# Install zenoh's router `zenohd` from crates.io, pinned to the zenoh version in our Cargo.lock,
# into target/zenohd-<version>/bin (kept between runs: skipped when already there). Prints the
# binary's path on stdout.
#
# Cost (measured on the 2-core machine, see docs/hosts.md, "The router for tests"): a cold install is about
# 6 CPU-minutes. To keep it there: only the features our clusters use (TCP links, user/password
# authentication; not zenohd's default set with QUIC, TLS, WebSocket, UDP, ...), zenohd's own
# Cargo.lock (--locked: the versions zenoh published it with), optimisation level 1 and no
# debug info, and the build directory removed afterwards (~650 MB). Sharing our target
# directory would share little: zenoh's crates are built with other features there.
set -euo pipefail
cd "$(dirname "$0")/../.."
version=$(awk '/^name = "zenoh"$/ {getline; gsub(/"/, "", $3); print $3; exit}' Cargo.lock)
[ -n "$version" ] || { echo "install-zenohd: no zenoh in Cargo.lock" >&2; exit 1; }
root="target/zenohd-$version"
bin="$root/bin/zenohd"
if [ -x "$bin" ] && "$bin" --version 2>/dev/null | grep -q "$version"; then
    echo "$PWD/$bin"
    exit 0
fi
echo "install-zenohd: building zenohd $version (cold: ~6 CPU-minutes)" >&2
start=$(date +%s)
CARGO_PROFILE_RELEASE_OPT_LEVEL=1 CARGO_PROFILE_RELEASE_DEBUG=false \
CARGO_PROFILE_RELEASE_INCREMENTAL=false \
    cargo install zenohd --version "=$version" --locked --no-default-features \
        --features zenoh/transport_tcp,zenoh/auth_usrpwd \
        --root "$root" --target-dir "$root/build" >&2
rm -rf "$root/build"
echo "install-zenohd: zenohd $version installed in $(( $(date +%s) - start )) s" >&2
echo "$PWD/$bin"
