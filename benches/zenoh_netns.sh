#!/usr/bin/env bash
# Round trips over zenoh next to iceoryx2, in one run: cliffd in a network namespace of
# its own ("server host"), cliff-bench once in the same namespace over iceoryx2 and over
# zenoh on loopback, and once from a second namespace ("client host") over zenoh across
# a veth pair, as two hosts would be. Every cliff-bench run uses --verify (each response
# compared bit for bit with the in-process prediction). Prints one JSON line per run and
# a summary with the median p50 and p99 per path.
#
#   cargo build --release -p cliff-service -p cliff-client --features cliff-service/zenoh,cliff-client/zenoh
#   sudo benches/zenoh_netns.sh [RUNS] [REQUESTS] > netns.jsonl
#
# Needs root and `ip netns`. Creates the namespaces cliffz-srv and cliffz-cli, the veth
# pair cliffz0/cliffz1 with 10.213.7.1/24 and 10.213.7.2/24 inside them (nothing else
# on the host sees these addresses), and removes them on exit. iceoryx2 prefix
# `cliffz_`, so it does not meet a daemon you already run. Bounded: RUNS (default 3)
# rounds of REQUESTS (default 2000, plus 200 warm-up) per path, each under `timeout`.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
requests=${2:-2000}
bin=${CARGO_TARGET_DIR:-target}/release
srv=cliffz-srv
cli=cliffz-cli
port=7447
export CLIFF_IPC_PREFIX="cliffz_"

if [ "$(id -u)" != 0 ]; then
    echo "needs root (network namespaces)" >&2
    exit 1
fi
for b in cliffd cliff-bench; do
    if ! "$bin/$b" --help | grep -q -- '--zenoh'; then
        echo "$bin/$b was built without the zenoh feature: see the build command above" >&2
        exit 1
    fi
done

daemon=
cleanup() {
    if [ -n "$daemon" ]; then
        kill -TERM "$daemon" 2>/dev/null || true
        wait "$daemon" 2>/dev/null || true
    fi
    ip netns del "$srv" 2>/dev/null || true
    ip netns del "$cli" 2>/dev/null || true
}
trap cleanup EXIT
cleanup

ip netns add "$srv"
ip netns add "$cli"
ip link add cliffz0 type veth peer name cliffz1
ip link set cliffz0 netns "$srv"
ip link set cliffz1 netns "$cli"
ip -n "$srv" addr add 10.213.7.1/24 dev cliffz0
ip -n "$cli" addr add 10.213.7.2/24 dev cliffz1
for ns in "$srv" "$cli"; do
    ip -n "$ns" link set lo up
done
ip -n "$srv" link set cliffz0 up
ip -n "$cli" link set cliffz1 up

ip netns exec "$srv" "$bin/cliffd" --zenoh "tcp/127.0.0.1:$port" --zenoh "tcp/10.213.7.1:$port" \
    > /tmp/cliffz-daemon.out 2> /tmp/cliffz-daemon.log &
daemon=$!
for _ in $(seq 100); do
    grep -q ready /tmp/cliffz-daemon.out 2>/dev/null && break
    sleep 0.1
done
grep -q ready /tmp/cliffz-daemon.out || { echo "cliffd did not start:" >&2; cat /tmp/cliffz-daemon.log >&2; exit 1; }

bench() {
    local case=$1 ns=$2
    shift 2
    local out
    out=$(timeout 300 ip netns exec "$ns" "$bin/cliff-bench" --json --verify \
        --requests "$requests" --warmup 200 --agents 1 --k 20 --steps 30 "$@")
    echo "{\"case\":\"$case\",\"time\":\"$(date -u +%H:%M:%S)\",\"bench\":$out}"
}

results=$(mktemp)
for _ in $(seq "$runs"); do
    bench iceoryx2-spin "$srv" --wait spin | tee -a "$results"
    bench iceoryx2-block "$srv" --wait block | tee -a "$results"
    bench zenoh-loopback "$srv" --zenoh "tcp/127.0.0.1:$port" | tee -a "$results"
    bench zenoh-veth "$cli" --zenoh "tcp/10.213.7.1:$port" | tee -a "$results"
done

python3 - "$results" >&2 <<'EOF'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
cases = []
for r in rows:
    if r["case"] not in cases:
        cases.append(r["case"])
print(f"{'path':<16} {'runs':>4} {'p50 us':>8} {'p99 us':>8} {'in-proc p50':>11} {'verified':>9}")
for c in cases:
    b = [r["bench"] for r in rows if r["case"] == c]
    p50 = statistics.median(x["p50_us"] for x in b)
    p99 = statistics.median(x["p99_us"] for x in b)
    ip = statistics.median(x["inprocess_p50_us"] for x in b)
    bad = sum(x["mismatches"] or 0 for x in b) + sum(x["errors"] for x in b)
    print(f"{c:<16} {len(b):>4} {p50:>8.1f} {p99:>8.1f} {ip:>11.1f} {'yes' if bad == 0 else 'NO':>9}")
EOF
rm -f "$results"
