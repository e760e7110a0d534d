#!/usr/bin/env bash
# Defaults when clients outnumber cores (docs/daemon.md, "Sharing one daemon"): four clients back to back on
# this machine's cores, agent-predictions per second with the default daemon and client
# settings (workers = cores, hybrid wait) next to the other daemon and client settings,
# measured in the same run (three rounds, interleaved); then one client alone with the
# default wait, its back-to-back p50 overhead over in-process.
# Prints one JSON line per run, then a summary.
#
#   cargo build --release -p cliff-service -p cliff-client
#   benches/defaults.sh
#
# Own iceoryx2 namespace (prefix `cliff_defaults_`). Needs both cores: close other work.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${CARGO_TARGET_DIR:-target}/release
export CLIFF_IPC_PREFIX="cliff_defaults_"
rounds=${ROUNDS:-3}
daemon=
stop() { if [ -n "$daemon" ]; then kill -INT "$daemon" 2>/dev/null || true; wait "$daemon" 2>/dev/null || true; fi; daemon=; }
trap stop EXIT
start() { "$bin/cliffd" "$@" > /dev/null 2>&1 & daemon=$!; sleep 1; }
out=$(mktemp)
for round in $(seq "$rounds"); do
    for workers in default 1; do
        if [ "$workers" = default ]; then start; else start --workers "$workers"; fi
        for wait in hybrid block spin; do
            for agents in 1 8; do
                j=$("$bin/cliff-bench" --json --no-verify --clients 4 --requests 2000 --warmup 100 \
                    --agents "$agents" --k 20 --steps 30 --wait "$wait")
                echo "{\"case\":\"workers-$workers/$wait/agents$agents\",\"round\":$round,\"bench\":$j}" | tee -a "$out"
            done
        done
        if [ "$workers" = default ]; then
            j=$("$bin/cliff-bench" --json --no-verify --clients 1 --requests 20000 --agents 1 --k 20 --steps 30 --wait hybrid)
            echo "{\"case\":\"one-client/hybrid\",\"round\":$round,\"bench\":$j}" | tee -a "$out"
        fi
        stop
    done
done
python3 - "$out" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
cases = sorted({r["case"] for r in rows if r["case"] != "one-client/hybrid"})
med = lambda c, k: statistics.median(r["bench"][k] for r in rows if r["case"] == c)
for agents in ("agents1", "agents8"):
    group = [c for c in cases if c.endswith(agents)]
    best = max(group, key=lambda c: med(c, "agent_predictions_per_s"))
    default = f"workers-default/hybrid/{agents}"
    for c in group:
        print(f"{c:32s} {med(c, 'agent_predictions_per_s'):9.0f} agent-predictions/s (median of rounds)")
    print(f"  default / best ({best}): {med(default, 'agent_predictions_per_s') / med(best, 'agent_predictions_per_s'):.1%}")
print(f"one client, hybrid: p50 overhead {med('one-client/hybrid', 'overhead_p50_us'):.1f} us "
      f"(p50 {med('one-client/hybrid', 'p50_us'):.1f} us, in-process {med('one-client/hybrid', 'inprocess_p50_us'):.1f} us)")
PY
rm -f "$out"
