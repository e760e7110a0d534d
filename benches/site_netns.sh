#!/usr/bin/env bash
# A site and a robot on two hosts (docs/zenoh.md, "A site with many robots"), as two
# network namespaces joined by a veth pair on this machine:
#
#   * site (10.213.9.1): cliffd --learn atc with a map built from one ATC training hour
#     (hour 10), listening on tcp/10.213.9.1:7447;
#   * robot (10.213.9.2): cliffd --follow atc=tcp/10.213.9.1:7447 (its own learning off),
#     a local client asking it 100 times a second all along (cliff-bench, over
#     iceoryx2), and `cliff observe --zenoh` streaming the other training hours' people to
#     the site as a robot's tracker would: each request the rows of EVERY_S (0.4) s of
#     recording time, sent when that time has come, the recording replayed SPEED (1600)
#     times faster than real time (an hour in 2.25 s);
#   * then the site is killed (SIGKILL) and restarted on its snapshot, and one more hour
#     is sent: the robot follows again.
#
# Prints, as JSON lines: how late the streamed requests went out after their time, the
# versions the site learned and the robot took, with the
# delay of each (from the two logs' times), the robot's requests and failures
# throughout, and the mean log-likelihood of atc/dev's people under the site's newest
# snapshot and the robot's (`cliff map score`), which must be within 0.05.
#
#   sudo benches/site_netns.sh            # the other ten hours (about a minute)
#   HOURS=3 sudo benches/site_netns.sh    # three of them
#   SPEED=360 EVERY_S=0.1 sudo benches/site_netns.sh   # slower, in smaller windows
#
# Exits non-zero unless the robot's newest snapshot scores within 0.05 of the site's,
# no request of the robot failed, and the robot took a version the restarted site
# learned. CLIFF_PREBUILT=1 uses the binaries in target/release as they are (CI: the
# zenoh test step built them).
#
# Needs root and `ip netns`; builds cliffd and the cliff binaries with the zenoh feature
# (release). Leaves its files in /tmp/cliff-site-netns. `.ci/run` runs it after the
# zenoh tests.
set -euo pipefail
cd "$(dirname "$0")/.."
data=$(cd ../shared/data/atc && pwd)
out=/tmp/cliff-site-netns
bin=$PWD/target/release
port=7447
site_ns=cliffs-site
robot_ns=cliffs-robot
endpoint="tcp/10.213.9.1:$port"
every_s=${EVERY_S:-0.4}
speed=${SPEED:-1600}

if [ -z "${CLIFF_PREBUILT:-}" ]; then
    cargo build --release -q -p cliff-service --features zenoh --bin cliffd
    cargo build --release -q -p cliff-client --features zenoh --bins
    cargo build --release -q -p cliff --bin cliff
fi
for b in cliff cliffd cliff-bench cliff-observe; do
    [ -x "$bin/$b" ] || { echo "$bin/$b is missing" >&2; exit 1; }
done
"$bin/cliff-observe" --help | grep -q -- --zenoh || { echo "$bin/cliff-observe was built without zenoh" >&2; exit 1; }

pids=()
cleanup() {
    for p in "${pids[@]}"; do
        kill -TERM "$p" 2>/dev/null || true
    done
    for p in "${pids[@]}"; do
        wait "$p" 2>/dev/null || true
    done
    ip netns del "$site_ns" 2>/dev/null || true
    ip netns del "$robot_ns" 2>/dev/null || true
}
trap cleanup EXIT
ip netns del "$site_ns" 2>/dev/null || true
ip netns del "$robot_ns" 2>/dev/null || true
ip netns add "$site_ns"
ip netns add "$robot_ns"
ip link add cliffs0 type veth peer name cliffs1
ip link set cliffs0 netns "$site_ns"
ip link set cliffs1 netns "$robot_ns"
ip -n "$site_ns" addr add 10.213.9.1/24 dev cliffs0
ip -n "$robot_ns" addr add 10.213.9.2/24 dev cliffs1
for ns in "$site_ns" "$robot_ns"; do
    ip -n "$ns" link set lo up
done
ip -n "$site_ns" link set cliffs0 up
ip -n "$robot_ns" link set cliffs1 up

rm -rf "$out"
mkdir -p "$out/site" "$out/robot"
first="$data/train/atc-1024-10_train.csv"
mapfile -t rest < <(ls "$data"/train/*.csv | grep -v 1024-10_train | head -n "${HOURS:-10}")
mapfile -t dev < <(ls "$data"/dev/*.csv)
scale=$("$bin/cliff" map build --format atc --grid 1 --radius 1 --tracks "$first" --out "$out/one-hour.cliff" |
    sed -n 's/.*busiest node *\([0-9]*\).*/\1/p')

# wait until FILE holds a line with "ready" (at most 60 s)
ready() {
    for _ in $(seq 600); do
        grep -q ready "$1" 2>/dev/null && return 0
        sleep 0.1
    done
    echo "not ready: $1" >&2
    cat "$1" >&2
    exit 1
}

# One session stands for the robots of a site, replayed SPEED times faster: its rows per
# second budget (--observe-rate) is well above the stream's (about 21,000 rows/s on
# average at 1600x), so that the stream is never held back by it.
site_args=(--prefix cliffs_site_ --map "atc=$out/one-hour.cliff" --learn atc --learn-dir "$out/site"
    --learn-count-scale "$scale" --learn-client-share 1 --learn-track-rows 100000
    --learn-move-per-min inf --observe-rate 100000 --observe-rows-held 65536
    --observe-tracks 4096 --track-timeout-s 0.5 --learn-every-s 3 --snapshot-every-s 1
    --zenoh "$endpoint")
start_site() {
    ip netns exec "$site_ns" "$bin/cliffd" "${site_args[@]}" >"$out/site-$1.out" 2>"$out/site-$1.log" &
    site_pid=$!
    pids+=("$site_pid")
    ready "$out/site-$1.out"
}
start_site 1
ip netns exec "$robot_ns" "$bin/cliffd" --prefix cliffs_robot_ --map "atc=$out/one-hour.cliff" \
    --follow "atc=$endpoint" --follow-dir "$out/robot" --follow-every-ms 200 \
    >"$out/robot.out" 2>"$out/robot.log" &
pids+=("$!")
ready "$out/robot.out"

# the robot's local client, 100 requests a second, until told to stop
touch "$out/polling"
(
    while [ -e "$out/polling" ]; do
        ip netns exec "$robot_ns" "$bin/cliff-bench" --prefix cliffs_robot_ --map atc \
            --map-file "$out/one-hour.cliff" --requests 500 --warmup 0 --rate 100 --keep-going \
            --no-verify --json 2>>"$out/bench.err" || { echo '{"bench":"failed"}'; sleep 1; }
    done >"$out/bench.jsonl"
) &
poller=$!
pids+=("$poller")

# the robot's tracker: rows streamed in windows of recording time; its closing lines say
# how many rows the site took and how late the requests went out
observe() {
    ip netns exec "$robot_ns" "$bin/cliff" observe --map atc --tracks "$@" --format atc \
        --zenoh "$endpoint" --quiet --give-up-s 30 --every-s "$every_s" --speed "$speed" |
        tee -a "$out/observe.out"
}
streamed() {
    sed -n 's/.*: \([0-9]*\) requests, sent after their time by \([0-9.]*\) ms median, \([0-9.]*\) ms p99, \([0-9.]*\) ms at most/"requests":\1,"late_median_ms":\2,"late_p99_ms":\3,"late_max_ms":\4/p' "$out/observe.out" | tail -n 1
}
t0=$(date +%s.%N)
observe "${rest[@]}" >/dev/null
echo "{\"phase\":\"observed\",\"hours\":${#rest[@]},\"seconds\":$(echo "$(date +%s.%N) - $t0" | bc),\"every_s\":$every_s,\"speed\":$speed,$(streamed)}"
sleep 8 # the last rows wait for the site's learning interval, the robot for its next question

newest() { ls "$1"/atc.v*.cliff 2>/dev/null | sort | tail -n 1; }
score() { "$bin/cliff" map score --map "$1" --tracks "${dev[@]}" --format atc --json | sed -n 's/.*"mean_log_likelihood": *\([-0-9.e]*\).*/\1/p'; }
site_snap=$(newest "$out/site")
robot_snap=$(newest "$out/robot")
site_score=$(score "$site_snap")
robot_score=$(score "$robot_snap")
same=$(cmp -s "$site_snap" "$robot_snap" && echo true || echo false)
echo "{\"phase\":\"scores\",\"site\":\"$(basename "$site_snap")\",\"robot\":\"$(basename "$robot_snap")\",\"same_bytes\":$same,\"site_score\":$site_score,\"robot_score\":$robot_score}"

# the site dies and comes back; one more hour, and the robot follows again
kill -KILL "$site_pid"
wait "$site_pid" 2>/dev/null || true
sleep 5
start_site 2
observe "$first" >/dev/null
sleep 8
rm -f "$out/polling"
wait "$poller" 2>/dev/null || true

# versions: when the site learned each (its logs) and when the robot took it (its log)
python3 - "$out" "$site_score" "$robot_score" <<'EOF'
import datetime, json, re, sys, glob
out = sys.argv[1]
def times(paths, pattern):
    seen = {}
    for p in paths:
        for line in open(p, errors="replace"):
            line = re.sub(r"\x1b\[[0-9;]*m", "", line)
            m = re.match(r"(\S+Z) .*" + pattern + r".*version=(\d+)", line)
            if m:
                t = datetime.datetime.fromisoformat(m.group(1).replace("Z", "+00:00")).timestamp()
                seen.setdefault((p, int(m.group(2))), t)
    return seen
site = times(sorted(glob.glob(f"{out}/site-*.log")), "learned a new version")
restarted = [v for (p, v) in site if p.endswith("site-2.log")]
robot = times([f"{out}/robot.log"], "took the site's version")
delays = []
for (sp, v), t in sorted(site.items(), key=lambda kv: kv[1]):
    later = [rt for (_, rv), rt in robot.items() if rv == v and rt >= t - 0.001]
    if later:
        delays.append(min(later) - t)
delays.sort()
print(json.dumps({"phase": "versions", "site_learned": len(site), "robot_took": len(robot),
                  "delay_median_ms": round(1e3 * delays[len(delays) // 2]) if delays else None,
                  "delay_max_ms": round(1e3 * delays[-1]) if delays else None}))
requests = failures = runs_failed = 0
for line in open(f"{out}/bench.jsonl"):
    try:
        j = json.loads(line)
    except ValueError:
        continue
    if j.get("bench") == "failed":
        runs_failed += 1
        continue
    requests += int(j.get("completed", 0))
    failures += int(j.get("failures", 0))
print(json.dumps({"phase": "robot requests", "requests": requests, "failures": failures,
                  "bench_runs_failed": runs_failed}))
site_score, robot_score = float(sys.argv[2]), float(sys.argv[3])
checks = {
    "the robot's snapshot scores within 0.05 of the site's": abs(site_score - robot_score) <= 0.05,
    "the robot answered every request": requests > 0 and failures == 0 and runs_failed == 0,
    "the robot took a version of the restarted site": bool(restarted)
    and any(v == max(restarted) for (_, v) in robot),
}
for what, ok in checks.items():
    print(("ok: " if ok else "FAILED: ") + what)
passed = sum(checks.values())
print(f"site_netns: {passed} passed, {len(checks) - passed} failed")
sys.exit(0 if passed == len(checks) else 1)
EOF
