#!/usr/bin/env bash
# A hostile remote client beside a remote and a local victim (docs/zenoh.md, "What a
# remote client may cost the daemon"): one default `cliffd --zenoh` on loopback; the
# victims (a zenoh client and an iceoryx2 client) send 1-agent requests (k 20, 30
# steps) at 100 Hz, first alone, then while one hostile zenoh session sends batches
# of FLOOD maximum-size requests at once (32 agents, k 50, 100 steps) and random,
# mutated and oversized payloads. RUNS rounds of both phases; one JSON line per phase
# and round (victims' p50/p99/max and failures, what the hostile client got back, the
# daemon's VmRSS before and VmHWM after), then a summary with the medians.
#
#   benches/zenoh_hostile.sh                      # 3 rounds of 2 x 20 s
#   RUNS=1 SECONDS_PER_PHASE=10 FLOOD=4000 benches/zenoh_hostile.sh
#   DAEMON_ARGS="--zenoh-nice 0" HOSTILE_NICE=19 benches/zenoh_hostile.sh
#
# DAEMON_ARGS are added to cliffd's arguments (e.g. --zenoh-nice 0 runs zenoh's threads
# at the serving loop's priority). The hostile client is a process of its own;
# HOSTILE_NICE (default 0) is its nice value: 19 stands in for a client on another
# host, whose CPU would not be the daemon's.
#
# Builds cliffd and the bench with the zenoh feature (release). Own iceoryx2 namespace
# (prefix `cliff_hostile_`) and port 27480. Needs both cores: close other work. Not in CI.
set -euo pipefail
cd "$(dirname "$0")/.."
export CLIFF_IPC_PREFIX="cliff_hostile_"
export CLIFF_ZENOH_ENDPOINT="tcp/127.0.0.1:27480"
export CLIFF_SERVICE="cliff/hostile"
export SECONDS_PER_PHASE=${SECONDS_PER_PHASE:-20}
export FLOOD=${FLOOD:-4000}
runs=${RUNS:-3}
cargo build --release -q -p cliff-service --features zenoh --bin cliffd
cargo bench -q -p cliff-service --features zenoh --bench zenoh_hostile --no-run 2>/dev/null
bench=$(ls -t "${CARGO_TARGET_DIR:-target}"/release/deps/zenoh_hostile-* | grep -v '\.d$' | head -1)
bin=${CARGO_TARGET_DIR:-target}/release
daemon=
stop() { if [ -n "$daemon" ]; then kill -INT "$daemon" 2>/dev/null || true; wait "$daemon" 2>/dev/null || true; fi; daemon=; }
trap stop EXIT
out=$(mktemp)
for run in $(seq "$runs"); do
    # shellcheck disable=SC2086 # DAEMON_ARGS is a list of arguments
    "$bin/cliffd" --service "$CLIFF_SERVICE" --zenoh "$CLIFF_ZENOH_ENDPOINT" ${DAEMON_ARGS:-} > /dev/null 2> "$out.log" &
    daemon=$!
    sleep 2
    CLIFF_DAEMON_PID=$daemon timeout $((4 * SECONDS_PER_PHASE + 60)) "$bench" \
        | sed "s/^{/{\"run\":$run,/" | tee -a "$out"
    grep -o 'memory_bound_mib=[0-9.]*' "$out.log" | head -1 | sed "s/^/run $run: daemon's /" >&2
    stop
done
python3 - "$out" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
for phase in ["alone", "beside-hostile"]:
    r = [x for x in rows if x["phase"] == phase]
    med = lambda f: statistics.median(f(x) for x in r)
    print(f"{phase}: remote p50 {med(lambda x: x['remote']['p50_us']):.0f} us, "
          f"p99 {med(lambda x: x['remote']['p99_us']):.0f} us, failures {sum(x['remote']['failures'] for x in r)}; "
          f"local p50 {med(lambda x: x['local']['p50_us']):.0f} us, "
          f"p99 {med(lambda x: x['local']['p99_us']):.0f} us, failures {sum(x['local']['failures'] for x in r)}; "
          f"daemon VmHWM {med(lambda x: x['daemon_hwm_kib']) / 1024:.1f} MiB "
          f"(VmRSS before {med(lambda x: x['daemon_rss_kib_before']) / 1024:.1f} MiB) ({len(r)} runs)")
PY
rm -f "$out" "$out.log"
