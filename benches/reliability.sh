#!/usr/bin/env bash
# Fault and soak figures of BENCHMARKS.md ("Sharing one daemon"), against real processes:
#
#   1. soak: 8 clients x 125,000 requests with --verify: no mismatch, no error;
#   2. 100 clients killed with SIGKILL mid-request (10 waves of 10) while two verified
#      clients run: those see no error and no mismatch, and afterwards every client slot
#      is free again (30 clients connect at once to a daemon of --max-clients 32);
#   3. the daemon killed with SIGKILL under load (4 clients at 500 Hz each, deadline 200 ms) and
#      restarted 2 s later: every client reports the failure within its deadline and
#      succeeds again after the restart.
#
#   cargo build --release -p cliff-service -p cliff-client
#   benches/reliability.sh            # all three; or: benches/reliability.sh soak|kill|restart
#
# Own iceoryx2 namespace (prefix `cliff_faults_`). Takes a few minutes; exits non-zero
# when a check fails. Prints each run's JSON line and a PASS/FAIL line per check.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${CARGO_TARGET_DIR:-target}/release
export CLIFF_IPC_PREFIX="cliff_faults_"
what=${1:-all}
log=$(mktemp)
daemon=
stop() { if [ -n "$daemon" ]; then kill -INT "$daemon" 2>/dev/null || true; wait "$daemon" 2>/dev/null || true; fi; daemon=; }
trap 'stop; rm -f "$log" "$log".*' EXIT
start() { "$bin/cliffd" "$@" >> "$log" 2>&1 & daemon=$!; sleep 1; }
failed=0
check() { # check NAME PYTHON-EXPR JSON
    if python3 -c "import json,sys; b=json.loads(sys.argv[1]); sys.exit(0 if ($2) else 1)" "$3"; then
        echo "PASS $1"
    else
        echo "FAIL $1"
        failed=1
    fi
}

if [ "$what" = all ] || [ "$what" = soak ]; then
    start
    t0=$(date +%s)
    j=$("$bin/cliff-bench" --json --clients 8 --requests 125000 --warmup 100 --verify --wait block || true)
    echo "{\"case\":\"soak\",\"seconds\":$(( $(date +%s) - t0 )),\"bench\":$j}"
    check "soak: 1,000,000 verified requests, no mismatch, no error" \
        'b["completed"] == 1000000 and b["mismatches"] == 0 and b["errors"] == 0' "$j"
    stop
fi

if [ "$what" = all ] || [ "$what" = kill ]; then
    start --max-clients 32 --cleanup-interval-ms 200
    "$bin/cliff-bench" --json --clients 2 --requests 40000 --warmup 100 --verify --wait block \
        > "$log.bystander" || true &
    bystander=$!
    killed=0
    for wave in $(seq 10); do
        pids=()
        for _ in $(seq 10); do
            "$bin/cliff-bench" --clients 1 --requests 100000000 --warmup 1 --agents 8 \
                --wait spin > /dev/null 2>&1 &
            pids+=($!)
        done
        sleep 0.5
        for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null && killed=$((killed + 1)); done
        wait "${pids[@]}" 2>/dev/null || true
    done
    wait "$bystander" || true
    j=$(cat "$log.bystander")
    echo "{\"case\":\"bystander-while-killing\",\"killed\":$killed,\"bench\":$j}"
    check "kill: $killed clients killed mid-request, bystanders unaffected" \
        "b['completed'] == 80000 and b['mismatches'] == 0 and b['errors'] == 0 and $killed == 100" "$j"
    sleep 1
    j=$("$bin/cliff-bench" --json --clients 30 --requests 200 --warmup 10 --wait block || true)
    echo "{\"case\":\"30-clients-after-kills\",\"bench\":${j:-null}}"
    check "kill: every dead client's slot freed (30 of 32 clients connect)" \
        'b is not None and b["completed"] == 6000 and b["errors"] == 0' "${j:-null}"
    echo "daemon log: $(grep -c 'removed resources of dead processes' "$log" || true) cleanup sweeps removed resources"
    stop
fi

if [ "$what" = all ] || [ "$what" = restart ]; then
    start
    "$bin/cliff-bench" --json --clients 4 --requests 4000 --rate 500 --warmup 10 --keep-going \
        --deadline-ms 200 --wait hybrid > "$log.clients" || true &
    clients=$!
    sleep 3
    kill -KILL "$daemon"; wait "$daemon" 2>/dev/null || true; daemon=
    sleep 2
    start
    wait "$clients" || true
    j=$(cat "$log.clients")
    echo "{\"case\":\"daemon-killed-and-restarted\",\"bench\":$j}"
    check "restart: failures reported within the 200 ms deadline, every client recovered" \
        'b["failures"] > 0 and b["slowest_failure_ms"] <= 210 and b["min_successes_after_last_failure"] > 0' "$j"
    stop
fi
exit "$failed"
