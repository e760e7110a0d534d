#!/usr/bin/env bash
# What learning costs other clients (docs/learning.md, "What learning costs the clients"):
# one `cliffd --learn` serving a map built from one ATC training hour. A client sends
# 1-agent requests (k 20, 30 steps) at 100 Hz with `cliff-bench`, in rounds that
# alternate: (quiet) nothing else; (learning) `cliff observe` streams the other training
# hours at the observe budget (--observe-rate, 20,000 rows/s here: the learner folds a
# version every 3 s or 20,000 rows), so the learner and the observe path work all
# round. One JSON line per round (p50/p99/p99.9/max in us, failures), then the medians.
#
#   benches/learning_p99.sh                 # 3 rounds of each, 2,000 requests per round
#   RUNS=5 REQUESTS=3000 benches/learning_p99.sh
#
# Responses are not compared with in-process predictions (--no-verify): the daemon
# answers from the versions it learns, the in-process side has the map as loaded.
#
# Uses target/release (build first: cargo build --release). Own iceoryx2 namespace
# (prefix `cliff_learning_p99_`). Needs both cores: close other work. Not in CI.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${CARGO_TARGET_DIR:-target}/release
runs=${RUNS:-3}
requests=${REQUESTS:-2000}
data=../shared/data/atc/train
work=$(mktemp -d)
[ -n "${KEEP:-}" ] && echo "work directory: $work" >&2
export CLIFF_IPC_PREFIX="cliff_learning_p99_"
daemon=
stop() { if [ -n "$daemon" ]; then kill -INT "$daemon" 2>/dev/null || true; wait "$daemon" 2>/dev/null || true; fi; daemon=; }
trap 'stop; [ -n "${KEEP:-}" ] || rm -rf "$work"' EXIT
"$bin/cliff" map build --tracks "$data/atc-1024-10_train.csv" --format atc --out "$work/hour.cliff" > /dev/null
rest=$(ls "$data"/*.csv | grep -v -- '-10_train')
round() { # $1: quiet or learning
    rm -rf "$work/learn"
    "$bin/cliffd" --map "atc=$work/hour.cliff" --learn atc --learn-dir "$work/learn" \
        --learn-client-share 1 --learn-track-rows 100000 --learn-move-per-min inf \
        --observe-rate 20000 --observe-rows-held 65536 --observe-tracks 4096 --track-timeout-s 0.5 \
        --learn-every-s 3 > "$work/cliffd.log" 2>&1 &
    daemon=$!
    sleep 2
    local observer=
    if [ "$1" = learning ]; then
        # shellcheck disable=SC2086 # the file list
        "$bin/cliff" observe --map atc --tracks $rest --format atc --quiet > "$work/observe.log" 2>&1 &
        observer=$!
        sleep 1
    fi
    "$bin/cliff-bench" --map atc --map-file "$work/hour.cliff" --agents 1 --k 20 --steps 30 \
        --requests "$requests" --warmup 100 --rate 100 --no-verify --json > "$work/bench.json" \
        2> "$work/bench.err" || { cat "$work/bench.err" >&2; exit 1; }
    local learned=0
    if [ -n "$observer" ]; then
        kill "$observer" 2>/dev/null || true
        wait "$observer" 2>/dev/null || true
    fi
    stop
    learned=$(grep -c "learned a new version" "$work/cliffd.log" || true)
    python3 - "$1" "$learned" "$work/bench.json" <<'PY'
import json, sys
phase, versions, path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
j = json.load(open(path))
print(json.dumps({"phase": phase, "versions_learned": versions,
                  **{k: j[k + "_us"] for k in ("p50", "p99", "p999", "max")},
                  "failures": j["failures"] + j["errors"] + (j["mismatches"] or 0)}))
PY
}
for _ in $(seq "$runs"); do
    round quiet
    round learning
done > "$work/rounds" # not a pipeline: the EXIT trap must see the daemon of this shell
cat "$work/rounds"
python3 - "$work/rounds" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
for phase in ("quiet", "learning"):
    r = [x for x in rows if x["phase"] == phase]
    print(f"{phase}: median p50 {statistics.median(x['p50'] for x in r):.1f} us, "
          f"median p99 {statistics.median(x['p99'] for x in r):.1f} us, failures {sum(x['failures'] for x in r)}")
PY
