#!/usr/bin/env bash
# Small requests beside the largest ones (docs/daemon.md, "Sharing one daemon"): while one client sends
# maximum-size requests back to back (32 agents x k 50 x 100 steps), a second client
# sends 1-agent requests (k 20, 30 steps) at 100 Hz; its p99 must stay under 1 ms.
# Three runs against one default cliffd, plus the small client alone for reference.
# Prints one JSON line per client and run, then a summary.
#
#   cargo build --release -p cliff-service -p cliff-client
#   benches/fairness.sh
#   BIG_METHOD=improved benches/fairness.sh   # the largest improved requests instead:
#                                             # 10 agents (cost factor 3)
#
# Own iceoryx2 namespace (prefix `cliff_fair_`). Needs both cores: close other work.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${CARGO_TARGET_DIR:-target}/release
export CLIFF_IPC_PREFIX="cliff_fair_"
runs=${RUNS:-3}
big_method=${BIG_METHOD:-cliff}
case "$big_method" in
    cliff) big_agents=32 ;;
    improved) big_agents=10 ;; # 32 x 50 x 100 positions / (50 x 100 x 3), rounded down
    *) echo "BIG_METHOD must be cliff or improved" >&2; exit 2 ;;
esac
daemon=
stop() { if [ -n "$daemon" ]; then kill -INT "$daemon" 2>/dev/null || true; wait "$daemon" 2>/dev/null || true; fi; daemon=; }
trap stop EXIT
"$bin/cliffd" "$@" > /dev/null 2>&1 &
daemon=$!
sleep 1
out=$(mktemp)
small() { "$bin/cliff-bench" --json --no-verify --agents 1 --k 20 --steps 30 --rate 100 --requests 1000 --warmup 20 --wait hybrid; }
echo "{\"case\":\"small-alone\",\"bench\":$(small)}" | tee -a "$out"
for run in $(seq "$runs"); do
    "$bin/cliff-bench" --json --no-verify --agents "$big_agents" --k 50 --steps 100 --requests 3000 \
        --warmup 20 --method "$big_method" --wait hybrid --deadline-ms 5000 > "$out.big" &
    big=$!
    sleep 1
    echo "{\"case\":\"small-beside-big\",\"run\":$run,\"bench\":$(small)}" | tee -a "$out"
    wait "$big"
    echo "{\"case\":\"big\",\"run\":$run,\"bench\":$(cat "$out.big")}" | tee -a "$out"
done
python3 - "$out" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
def med(case, key):
    v = [r["bench"][key] for r in rows if r["case"] == case]
    return statistics.median(v), v
for case in ("small-alone", "small-beside-big"):
    for key in ("p50_us", "p99_us", "max_us"):
        m, v = med(case, key)
        print(f"{case:18s} {key:7s} median {m:8.1f}   runs {', '.join(f'{x:.1f}' for x in v)}")
m, v = med("big", "p50_us")
print(f"{'big':18s} p50_us  median {m:8.1f}   runs {', '.join(f'{x:.1f}' for x in v)}")
PY
rm -f "$out" "$out.big"
