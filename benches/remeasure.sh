#!/usr/bin/env bash
# Every row of BENCHMARKS.md, measured again in one session, for a quiet machine.
#
#   benches/remeasure.sh --list              # the rows and their commands; nothing runs
#   benches/remeasure.sh                     # every subject, one after the other
#   benches/remeasure.sh predictor daemon    # some subjects
#   ONLY='batch|eval' benches/remeasure.sh predictor   # the rows whose label matches
#
# Subjects (in BENCHMARKS.md's order): predictor motion accuracy ros2 build python
# daemon sharing zenoh learning; `zenoh-build` (two fresh builds in empty target
# directories, about half an hour on two idle cores) only when named.
#
# Builds what the rows need first (release, `-j 1`; NO_BUILD=1 takes the binaries as
# they are), then runs each row's command and
# prints, per row, the date, the load average, the command and the lines of its output
# that hold the figures; at the end, one Markdown line per row (what, figures, command,
# host, date) to put in place of BENCHMARKS.md's. Every command's whole output is kept
# in OUT (default: a new directory under /tmp, named at the start).
#
# Needs the datasets in ../shared/data. The python row needs the package in .venv
# (`.ci/test` installs it; VENV= names another); the callgrind row valgrind; the zenoh
# veth row root (`sudo`, skipped otherwise). Daemons run in their own iceoryx2 namespace
# (prefix `cliff_remeasure_`). Close other work first: the rows need both cores.
set -uo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
bin=${CARGO_TARGET_DIR:-target}/release
venv=${VENV:-.venv}
only=${ONLY:-}
export CLIFF_IPC_PREFIX="cliff_remeasure_"

all_subjects=(predictor motion accuracy ros2 build python daemon sharing zenoh learning)
list=0
subjects=()
for a in "$@"; do
    case "$a" in
        --list) list=1 ;;
        -h | --help) sed -n '2,22p' "$0"; exit 0 ;;
        predictor | motion | accuracy | ros2 | build | python | daemon | sharing | zenoh | zenoh-build | learning) subjects+=("$a") ;;
        *) echo "unknown subject '$a' (see --help)" >&2; exit 2 ;;
    esac
done
[ ${#subjects[@]} -gt 0 ] || subjects=("${all_subjects[@]}")

out=${OUT:-OUT}
if [ "$list" = 0 ]; then
    out=${OUT:-$(mktemp -d /tmp/cliff-remeasure-XXXXXX)}
    mkdir -p "$out"
    summary="$out/rows.md"
    : > "$summary"
    echo "output: $out"
    echo "host: $(uname -n), $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'); $(rustc --version 2>/dev/null)"
    echo "commit: $(git rev-parse --short HEAD 2>/dev/null)$(git diff --quiet 2>/dev/null || echo ' (with local changes)')"
fi
n=0
daemon=
stop_daemon() { if [ -n "$daemon" ]; then kill -INT "$daemon" 2>/dev/null || true; wait "$daemon" 2>/dev/null || true; fi; daemon=; }
trap stop_daemon EXIT
start_daemon() { # cliffd ARGS...
    stop_daemon
    [ "$list" = 1 ] && return 0
    "$bin/cliffd" "$@" > "$out/cliffd.log" 2>&1 &
    daemon=$!
    for _ in $(seq 100); do grep -q 'cliffd ready' "$out/cliffd.log" 2>/dev/null && return 0; sleep 0.1; done
    echo "cliffd $* did not start:" >&2
    tail -5 "$out/cliffd.log" >&2
}

# row SUBJECT 'WHAT' 'PATTERN' COMMAND...: runs COMMAND (bash -c), prints the lines of
# its output that match the extended regular expression PATTERN ('' = the last 15).
row() {
    local subject=$1 what=$2 pattern=$3
    shift 3
    local cmd="$*"
    if [ -n "$only" ] && ! [[ "$what" =~ $only ]]; then
        return 0
    fi
    n=$((n + 1))
    if [ "$list" = 1 ]; then
        printf '%-10s %s\n           $ %s\n' "$subject" "$what" "$cmd"
        return 0
    fi
    local log
    log=$(printf '%s/%02d-%s.log' "$out" "$n" "$subject")
    local date load
    date=$(date -u '+%Y-%m-%d %H:%M UTC')
    load=$(cut -d' ' -f1-3 /proc/loadavg)
    echo
    echo "== $subject: $what"
    echo "   $date, load average $load"
    echo "   \$ $cmd"
    bash -c "$cmd" > "$log" 2>&1
    local rc=$?
    local lines
    if [ -n "$pattern" ]; then
        lines=$(grep -E -- "$pattern" "$log" | tail -n 40)
    else
        lines=$(tail -n 15 "$log")
    fi
    [ "$rc" = 0 ] || lines="$lines
(exit status $rc; whole output in $log)"
    printf '%s\n' "$lines" | sed 's/^/   /'
    local figure
    figure=$(printf '%s\n' "$lines" | sed 's/[[:space:]]\+/ /g; s/|/\\|/g' | paste -sd ';' -)
    printf '| %s | %s | `%s` | %s, load %s | %s |\n' "$what" "$figure" "$cmd" "$(uname -n)" "$load" "$date" >> "$summary"
}

# The executable `cargo bench` builds for a bench target (for profilers and repeated runs).
bench_binary() { # PACKAGE BENCH
    cargo bench -j 1 -p "$1" --bench "$2" --no-run --message-format=json 2>/dev/null |
        python3 -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == sys.argv[1] and m.get("executable"):
        print(m["executable"])' "$2"
}

build() {
    [ "$list" = 1 ] || [ -n "${NO_BUILD:-}" ] && return 0
    echo "building (release, -j 1) ..."
    cargo build -q --release -j 1 -p cliff -p cliff-service -p cliff-client || exit 1
}

want() { local s; for s in "${subjects[@]}"; do [ "$s" = "$1" ] && return 0; done; return 1; }

crit='time: |^[a-z0-9_/]+ *$'   # criterion: the bench's name, then its time line
opts='^case|^(thor1|atc)_person'  # options_cost's table
build

if want predictor; then
    row predictor 'the paper'"'"'s method, THÖR1 person (criterion)' "$crit" \
        "cargo bench -j 1 --bench predict -- '^thor1_person_k20_30steps\$'"
    for i in 1 2 3; do
        row predictor "the paper's method on both paths, and improved, run $i of 3" "$opts" \
            "cargo bench -j 1 --bench options_cost -- 200 20 improved"
    done
    for p in thor1 atc; do
        for i in 1 2 3; do
            row predictor "improved / the paper, $p, both paths alternating, run $i of 3" "$opts" \
                "cargo bench -j 1 --bench options_cost -- 200 20 improved $p"
            row predictor "improved / the paper, $p, AVX2 path alone, run $i of 3" "$opts" \
                "cargo bench -j 1 --bench options_cost -- 200 20 improved $p avx2"
        done
    done
    if command -v valgrind > /dev/null; then
        oc=options_cost-HASH
        [ "$list" = 1 ] || oc=$(bench_binary cliff options_cost)
        for p in thor1 atc; do
            for path in '' baseline; do
                row predictor "instructions, the paper's method, $p ${path:-both paths}" 'TOTALS|predict_agents|Collected' \
                    "valgrind --tool=callgrind --callgrind-out-file=$out/callgrind.$p${path:+.$path} $oc 10 20 none $p $path && callgrind_annotate --inclusive=yes $out/callgrind.$p${path:+.$path} | grep -m3 -E 'predict_agents|TOTALS|PROGRAM'"
            done
        done
    fi
    row predictor 'scores on both paths' "$opts" "cargo bench -j 1 --bench options_cost -- 200 20 scores"
    row predictor 'speed kernel, coasting, both, all three' "$opts" \
        "cargo bench -j 1 --bench options_cost -- 200 10 speed coast speed_scores all"
    row predictor 'the options and time-of-day slices (criterion)' "$crit" \
        "cargo bench -j 1 --bench predict -- --warm-up-time 2 --measurement-time 4 'person_k20_(30|50)steps(_scores|_speed|_coast|_speed_scores|_all|_set_all_day|_set_slice)?\$'"
    row predictor 'constant velocity, THÖR1 person' "$crit" "cargo bench -j 1 --bench predict -- cvm_thor1_person"
    row predictor 'occupancy: 30 people, k 20, 30 times onto 200 x 200 cells (criterion)' "$crit" "cargo bench -j 1 --bench occupancy"
    row predictor 'predict_batch, 1,000 ATC people, 1 and 2 threads' 'threads|^ +[0-9]' "cargo bench -j 1 --bench batch -- 10"
    row predictor 'predict_batch with improved' 'threads|^ +[0-9]' "cargo bench -j 1 --bench batch -- 5 improved"
    row predictor 'cliff eval on THÖR1, parity settings, 20 seeds' 'people evaluated' \
        "$bin/cliff eval --map ../shared/data/thor1/cliffmap.csv --tracks ../shared/data/thor1/exp-1-run-2.csv --format thor --protocol reference --obs 3.2 --dt 0.4 --horizon 12 --radius 0.7071 --beta 1 --k 20 --seeds 20 --methods cliff,cvm --out $out/thor1-eval"
fi

if want motion; then
    row motion 'motion model forecast, motion, the paper (criterion)' "$crit" \
        "cargo bench -j 1 --bench predict -- 'motion|^thor1_person_k20_30steps\$' --measurement-time 3 --warm-up-time 1"
fi

if want accuracy; then
    row accuracy "improved and the paper on atc/dev (held out)" '^\|' "python3 benches/beyond.py --only 1 --out $out/beyond"
    row accuracy 'improved against the motion model, constant velocity and the paper, every dataset' '' \
        "python3 benches/horizons.py --out $out/horizons"
fi

if want ros2; then
    row ros2 'the ROS 2 node, stage by stage' 'p50|p99|time: |^[a-z_/]+ *$' "cargo bench -j 1 -p cliff-ros2 --bench node"
    row ros2 'no allocation on the steady path' 'test result|no_alloc|allocat' "cargo test -j 1 --release -p cliff-ros2 --test no_alloc"
fi

if want build; then
    row build 'map building (criterion)' "$crit" "cargo bench -j 1 --bench build"
    row build 'cliff map build, all of ATC train, end to end' 'locations|time|real|user' \
        "bash -c 'time $bin/cliff map build --tracks ../shared/data/atc/train/*.csv --format atc --grid 1 --radius 1 --out $out/atc-train.csv'"
fi

if want python; then
    if [ "$list" = 1 ] || [ -x "$venv/bin/python" ]; then
        row python 'cliff_lhmp against the Rust call and a NumPy re-statement' 'us|ms' "$venv/bin/python benches/python_predict.py"
    else
        echo "python: no $venv/bin/python (run .ci/test, or set VENV=): skipped" >&2
    fi
fi

if want daemon; then
    row daemon 'latency (9 x spin, hybrid, block) and throughput (4 clients, workers 2 and 1)' '' \
        "benches/daemon_series.sh > $out/series.jsonl; python3 -c 'import json,sys
for l in open(sys.argv[1]):
    j=json.loads(l); b=j[\"bench\"]; print(j[\"case\"], j[\"time\"], json.dumps(b)[:400])' $out/series.jsonl"
    start_daemon
    for wait in spin block; do
        for i in 1 2 3; do
            row daemon "against the transport floor, --wait $wait, run $i of 3" '^\|' \
                "$bin/cliff-bench --compare --clients 1 --requests 5000 --wait $wait --out $out/compare-$wait-$i && cat $out/compare-$wait-$i/report.md"
        done
    done
    row daemon 'the --compare report, hybrid, 1, 2 and 4 clients' '^\|' \
        "$bin/cliff-bench --compare --clients 1,2,4 --requests 5000 --out $out/compare && cat $out/compare/report.md"
    for wait in hybrid block spin; do
        row daemon "paced 10 Hz, default cliffd, --wait $wait" 'p50 +p90|round trip through|in-process prediction|overhead' \
            "$bin/cliff-bench --requests 100 --warmup 10 --rate 10 --wait $wait"
    done
    start_daemon --idle-spin-us 200000
    for wait in hybrid block spin; do
        row daemon "paced 10 Hz, cliffd --idle-spin-us 200000, --wait $wait" 'p50 +p90|round trip through|in-process prediction|overhead' \
            "$bin/cliff-bench --requests 100 --warmup 10 --rate 10 --wait $wait"
    done
    atc=../shared/data/atc/cliffmap-20121024.csv
    for i in 1 2 3; do
        for w in 1 2; do
            start_daemon --map "atc=$atc" --workers "$w"
            row daemon "one request of 32 ATC agents, --workers $w, run $i of 3" 'p50 +p90|round trip through|in-process prediction|overhead' \
                "$bin/cliff-bench --map atc --map-file $atc --agents 32 --k 20 --steps 50 --dt 1 --requests 200 --warmup 10 --wait block"
        done
    done
    stop_daemon
fi

if want sharing; then
    row sharing 'small requests beside the largest ones' '' "benches/fairness.sh"
    row sharing 'small requests beside the largest improved ones' '' "BIG_METHOD=improved benches/fairness.sh"
    row sharing 'defaults when clients outnumber cores' '' "benches/defaults.sh"
    row sharing 'faults and soak' 'PASS|FAIL' "benches/reliability.sh"
    row sharing "a learning daemon's other clients" '' "benches/learning_p99.sh"
fi

if want zenoh; then
    row zenoh 'a hostile remote client, zenoh at nice +10' '' "RUNS=2 SECONDS_PER_PHASE=15 benches/zenoh_hostile.sh"
    row zenoh "a hostile remote client, zenoh at the daemon's priority" '' \
        "DAEMON_ARGS='--zenoh-nice 0' RUNS=2 SECONDS_PER_PHASE=15 benches/zenoh_hostile.sh"
    row zenoh 'a hostile remote client at nice 19' '' "HOSTILE_NICE=19 benches/zenoh_hostile.sh"
    for i in 1 2 3; do
        row zenoh "a site and a following robot on one host, run $i of 3" '' "SECONDS_PER_PHASE=5 benches/site_follow.sh"
    done
    # as root directly (a container may have no sudo), otherwise through sudo
    root_cmd='sudo -n'
    [ "$(id -u)" = 0 ] && root_cmd=
    if [ -z "$root_cmd" ] || sudo -n true 2> /dev/null; then
        row zenoh 'round trips over zenoh (loopback, veth) next to iceoryx2' '' \
            "cargo build -q --release -j 1 -p cliff-service -p cliff-client --features cliff-service/zenoh,cliff-client/zenoh && $root_cmd benches/zenoh_netns.sh 3 2000"
        row zenoh 'a site and a robot on two hosts (network namespaces)' '' "$root_cmd bash benches/site_netns.sh"
    else
        echo "zenoh: the veth row needs root (sudo benches/remeasure.sh zenoh): skipped" >&2
    fi
fi

if want zenoh-build; then
    row zenoh-build 'cliffd without zenoh, empty target directory' 'Elapsed|User time|System time' \
        "rm -rf /tmp/cliff-t-off && CARGO_TARGET_DIR=/tmp/cliff-t-off /usr/bin/time -v cargo build -q --release -p cliff-service --bin cliffd"
    row zenoh-build 'cliffd with zenoh, empty target directory' 'Elapsed|User time|System time' \
        "rm -rf /tmp/cliff-t-on && CARGO_TARGET_DIR=/tmp/cliff-t-on /usr/bin/time -v cargo build -q --release -p cliff-service --bin cliffd --features zenoh"
fi

if want learning; then
    row learning 'a daemon that learns its site (held-out score and ADE)' '' "python3 benches/learning.py --all-people --out $out/learning"
fi

if [ "$list" = 0 ]; then
    echo
    echo "== rows (what | figures | command | host | date)"
    cat "$summary"
fi
