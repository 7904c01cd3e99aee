#!/usr/bin/env bash
# What the scenarios of clusters on several hosts (tests/scenarios/hosts.rs) need: zenoh's
# router `zenohd` (pinned to our zenoh, tests/hosts/install-zenohd.sh) and, for the network
# namespace run, iproute2's `ip` (installed from the distribution when missing and root).
# Never fails the run: what cannot be had is said here, and the tests that need it say
# "SKIPPED ..." and return.
set -uo pipefail
cd "$(dirname "$0")/../.."
if ! command -v ip >/dev/null 2>&1; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        echo "hosts: installing iproute2" >&2
        (apt-get install -y -q iproute2 >/dev/null 2>&1 \
            || { apt-get update -q >/dev/null 2>&1 && apt-get install -y -q iproute2 >/dev/null 2>&1; }) \
            || echo "hosts: cannot install iproute2: the network-namespace scenario will be SKIPPED" >&2
    else
        echo "hosts: no \`ip\` and not root: the network-namespace scenario will be SKIPPED" >&2
    fi
fi
[ "$(id -u)" = 0 ] || echo "hosts: not root: the network-namespace scenario will be SKIPPED" >&2
if ! bash tests/hosts/install-zenohd.sh >/dev/null; then
    echo "hosts: zenohd could not be installed: the router scenarios will be SKIPPED" >&2
fi
exit 0
