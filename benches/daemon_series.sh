#!/usr/bin/env bash
# The daemon figures of BENCHMARKS.md in one go: one cliffd, nine spin latency runs, one
# hybrid and one block run (one agent, k 20, 30 steps), then throughput with four
# blocking clients against `cliffd --workers 2` and `--workers 1` (8-agent and 1-agent
# requests, three runs each). Prints one line per run: the case, the clock time and the
# `cliff-bench --json` object.
#
#   cargo build --release -p cliff-service -p cliff-client
#   benches/daemon_series.sh > series.jsonl
#
# Runs in its own iceoryx2 namespace (prefix `cliff_series_`), so it does not meet a
# daemon you already run. Needs both cores to itself: close other work first.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${CARGO_TARGET_DIR:-target}/release
export CLIFF_IPC_PREFIX="cliff_series_"
daemon=
stop() { if [ -n "$daemon" ]; then kill -INT "$daemon" 2>/dev/null || true; wait "$daemon" 2>/dev/null || true; fi; daemon=; }
trap stop EXIT
start() {
    "$bin/cliffd" "$@" > /dev/null 2>&1 &
    daemon=$!
    sleep 1
}
run() {
    local case=$1
    shift
    echo "{\"case\":\"$case\",\"time\":\"$(date +%H:%M:%S)\",\"bench\":$("$bin/cliff-bench" --json --no-verify "$@")}"
}
start
for _ in 1 2 3 4 5 6 7 8 9; do
    run spin --clients 1 --requests 20000 --agents 1 --k 20 --steps 30 --wait spin
done
for wait in hybrid block; do
    run "$wait" --clients 1 --requests 20000 --agents 1 --k 20 --steps 30 --wait "$wait"
done
stop
for workers in 2 1; do
    start --workers "$workers"
    for agents in 8 1 8 1 8 1; do
        run "throughput-workers$workers-agents$agents" \
            --clients 4 --requests 1000 --agents "$agents" --k 20 --steps 30 --wait block
    done
    stop
done
