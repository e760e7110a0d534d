#!/usr/bin/env bash
# cliff-ros2 against a real ROS 2 (Jazzy from its PyPI wheels, rclpy over Fast DDS):
# an rclpy node publishes THÖR1 round 2 as people_msgs/People at 2.5 Hz, cliff-ros2
# predicts in-process from the THÖR1 map, an rclpy node receives the predictions and
# markers, and verify.py compares them with the in-process reference for the same
# histories and seed. Every ROS 2 process runs in a private network namespace
# (loopback only). Closes with `N passed, N failed`; exits non-zero on a failure.
#
#   bash ros2/tests/run_rclpy.sh            # FRAMES=100 (40 s of the recording)
set -uo pipefail
here="$(cd "$(dirname "$0")" && pwd)"   # ros2/tests
ros2="$(dirname "$here")"
repo="$(dirname "$ros2")"
data="${CLIFF_DATA:-$repo/../shared/data}"
frames="${FRAMES:-100}"
passed=0
failed=0
t0=$SECONDS

finish() {
  echo "ros2 tests took $((SECONDS - t0)) s"
  echo "$passed passed, $failed failed"
  [ "$failed" -eq 0 ]
  exit $?
}

if ! bash "$here/setup_ros2.sh"; then
  echo "FAIL setup: ROS 2 wheels or message packages"; failed=$((failed + 1)); finish
fi
target="${CARGO_TARGET_DIR:-$repo/target}/release"
if [ -n "${CLIFF_ROS2_PREBUILT:-}" ]; then
  # CI: the workspace's cargo test already built them; use those, build nothing
  for bin in cliff-ros2 cliff-ros2-reference cliffd; do
    [ -x "$target/$bin" ] || { echo "FAIL build: $target/$bin is missing (CLIFF_ROS2_PREBUILT is set)"; failed=$((failed + 1)); finish; }
  done
elif ! (cd "$repo" && cargo build --release -p cliff-ros2 -p cliff-service --quiet); then
  echo "FAIL build: cliff-ros2 and cliffd"; failed=$((failed + 1)); finish
fi
map="$data/thor1/cliffmap.csv"
tracks="$data/thor1/exp-1-run-2.csv"
components=$(grep -c . "$map")
# shellcheck disable=SC1091
. "$here/ros2_env.sh"

# The ament package cliff_ros2 built as `colcon build` builds it in a ROS 2 workspace: its
# CMakeLists.txt runs cargo on this workspace's target folder (CARGO_TARGET_DIR; the
# binaries above are up to date, so nothing is rebuilt) and installs cliff-ros2, cliffd,
# the launch file and the parameters file. Then what `ros2 run cliff_ros2 cliff-ros2`
# resolves (the package prefix from the ament index, lib/cliff_ros2/EXECUTABLE) runs.
check() {  # check OK-OR-NOT TEXT
  if [ "$1" = 0 ]; then echo "ok   package: $2"; passed=$((passed + 1)); else echo "FAIL package: $2"; failed=$((failed + 1)); fi
}
t2=$SECONDS
ln -sfn "$ros2/cliff_ros2" "$ros2/.ws/src/cliff_ros2"
# CI (CLIFF_ROS2_PREBUILT): cargo test built the binaries with its own feature set, which
# cargo build would rebuild (minutes): the package installs them as they are
cargo_build=ON; [ -z "${CLIFF_ROS2_PREBUILT:-}" ] || cargo_build=OFF
(cd "$ros2/.ws" && CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$repo/target}" CMAKE_PREFIX_PATH="$VIRTUAL_ENV" \
  colcon build --paths src/cliff_ros2 --event-handlers console_direct- \
  --cmake-args -DPython3_EXECUTABLE="$VIRTUAL_ENV/bin/python" -DBUILD_TESTING=OFF -DCLIFF_CARGO_BUILD=$cargo_build \
  >"$ros2/.ws/cliff_ros2.log" 2>&1)
check $? "colcon build of cliff_ros2 (cargo build in CMake: $cargo_build; $((SECONDS - t2)) s; log ros2/.ws/cliff_ros2.log)"
export AMENT_PREFIX_PATH="$ros2/.ws/install/cliff_ros2:$AMENT_PREFIX_PATH"
prefix="$(python -c 'from ament_index_python.packages import get_package_prefix as p; print(p("cliff_ros2"))' 2>/dev/null)"
share="$prefix/share/cliff_ros2"
"$prefix/lib/cliff_ros2/cliff-ros2" --help 2>/dev/null | grep -q "cliff/objects"
check $? "the ament index finds cliff_ros2 ($prefix) and lib/cliff_ros2/cliff-ros2 --help runs, as ros2 run does"
"$prefix/lib/cliff_ros2/cliffd" --help >/dev/null 2>&1
check $? "lib/cliff_ros2/cliffd --help runs"
cmp -s "$share/config/cliff.yaml" "$ros2/config/cliff.yaml" && [ -s "$share/launch/cliff.launch.py" ] && [ -s "$share/cliff.rviz" ]
check $? "share/cliff_ros2 holds launch/cliff.launch.py, config/cliff.yaml and cliff.rviz"

# scenario NAME DAEMON_ARGS MAP_LABEL NODE_ARGS... : run the processes in a fresh network
# namespace (cliff-ros2 first; then cliffd with DAEMON_ARGS unless it is "-"; then the
# rclpy listener and publisher), then verify. Set before the call (reset after it):
# PUB (more publisher arguments), VERIFY (an array of more verify.py arguments; @TMP@
# is the scenario's folder), FRAMES_OF (frames),
# RESTART=1 (stop cliffd 12 s into the publishing and start it again 8 s later);
# @TMP@ in DAEMON_ARGS is the scenario's folder too.
PUB=""; VERIFY=(); FRAMES_OF=""; RESTART=""
scenario() {
  local name="$1"; local daemon="$2"; local label="$3"; shift 3
  local tmp; tmp="$(mktemp -d)"
  local t1=$SECONDS
  daemon="${daemon//@TMP@/$tmp}"
  unshare -n bash -c '
    ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
    export ROS_DOMAIN_ID=42
    tmp="$1"; target="$2"; here="$3"; tracks="$4"; frames="$5"; daemon="$6"; pub="$7"; restart="$8"; shift 8
    export CLIFF_IPC_PREFIX="cliffros2test$$"
    bin="${CLIFF_BIN:-$target}"
    "$bin/cliff-ros2" "$@" >"$tmp/node.log" 2>&1 & node=$!
    dpid=""
    if [ "$daemon" != "-" ]; then
      sleep 1   # the node first: it must find the daemon by itself
      # shellcheck disable=SC2086
      "$bin/cliffd" $daemon >"$tmp/cliffd.log" 2>&1 & dpid=$!
      echo $dpid >"$tmp/dpid"
      for _ in $(seq 100); do grep -q ready "$tmp/cliffd.log" && break; sleep 0.1; done
    fi
    restarter=""
    if [ -n "$restart" ] && [ -n "$dpid" ]; then
      (
        for _ in $(seq 600); do [ -e "$tmp/started" ] && break; sleep 0.1; done
        sleep 12
        kill "$dpid"; wait "$dpid" 2>/dev/null
        date +%s.%N >"$tmp/gone"
        sleep 8
        date +%s.%N >"$tmp/back"
        # shellcheck disable=SC2086
        "$bin/cliffd" $daemon >"$tmp/cliffd2.log" 2>&1 & echo $! >"$tmp/dpid"
      ) & restarter=$!
    fi
    python "$here/rclpy/listen.py" --ready "$tmp/ready" --done "$tmp/sent.json" --out "$tmp/received.json" \
      --linger 4 2>"$tmp/listen.log" & listener=$!
    # shellcheck disable=SC2086
    python "$here/rclpy/publish_people.py" --tracks "$tracks" --frames "$frames" \
      --wait-for "$tmp/ready" --started "$tmp/started" --out "$tmp/sent.json" $pub 2>"$tmp/publish.log"
    wait $listener
    [ -z "$restarter" ] || wait "$restarter"
    kill $node 2>/dev/null; wait $node 2>/dev/null
    if [ -n "$dpid" ]; then
      # SIGTERM, then wait for its closing lines (a learning daemon writes its snapshot)
      dpid=$(cat "$tmp/dpid"); kill "$dpid" 2>/dev/null
      for _ in $(seq 100); do kill -0 "$dpid" 2>/dev/null || break; sleep 0.1; done
    fi
    true' _ "$tmp" "$target" "$here" "$tracks" "${FRAMES_OF:-$frames}" "$daemon" "$PUB" "$RESTART" "$@"
  echo "scenario $name ran in $((SECONDS - t1)) s (logs in $tmp)"
  if [ ! -s "$tmp/sent.json" ] || [ ! -s "$tmp/received.json" ]; then
    echo "FAIL $name: no exchange"; tail -n 5 "$tmp"/*.log; failed=$((failed + 1)); PUB=""; VERIFY=(); FRAMES_OF=""; RESTART=""; return
  fi
  local out
  VERIFY=("${VERIFY[@]//@TMP@/$tmp}")
  out="$(python "$here/rclpy/verify.py" --name "$name" --sent "$tmp/sent.json" --received "$tmp/received.json" \
      --reference "$target/cliff-ros2-reference" --map "$map" --map-components "$components" \
      --map-label "$label" --timeout 1.8 --log "$tmp/node.log" "${VERIFY[@]}")"
  echo "$out" | grep -v ' passed, .* failed$'
  local p f
  p=$(echo "$out" | grep -c '^ok ')
  f=$(echo "$out" | grep -c '^FAIL ')
  passed=$((passed + p)); failed=$((failed + f))
  [ "$f" -eq 0 ] || tail -20 "$tmp/node.log"
  PUB=""; VERIFY=(); FRAMES_OF=""; RESTART=""
}

# golden CDR bytes and type hashes: rosbags and the official generator against the
# committed files (cargo test's tests/golden.rs checks our structs against the same files)
gout="$(python "$here/golden/make_golden.py" --check)"
echo "$gout" | grep -v ' passed, .* failed$'
passed=$((passed + $(echo "$gout" | grep -c '^ok '))); failed=$((failed + $(echo "$gout" | grep -c '^FAIL ')))

common=(-p rate:=0.0 -p track_timeout:=1.8 -p warn_period:=2.0)

# People from a reliable publisher, in-process; every track's markers deleted once stale
VERIFY=(--all-deleted)
scenario in-process - "$map" --map "$map" "${common[@]}"

# through cliffd, started after the node, stopped for 8 s in the middle and started again
RESTART=1
VERIFY=(--all-deleted --gone @TMP@/gone --back @TMP@/back --min-received 0.55
        --warn "no prediction this cycle:1:7" --warn "predictions are back:1:3")
scenario cliffd "--map thor1=$map" thor1 -p daemon_map:=thor1 -p map_markers_file:="$map" "${common[@]}"

# through a cliffd that learns the map: the node sends it every track's rows as
# observations (parameter observe); cliffd takes each row once and each track's end, and
# learns them at shutdown (no version during the run: the predictions stay the map's)
VERIFY=(--all-deleted --observed @TMP@/cliffd.log --learned @TMP@/learned)
scenario observe "--map thor1=$map --learn thor1 --learn-dir @TMP@/learned --learn-every-s 3600 --learn-every-rows 1000000" \
  thor1 -p daemon_map:=thor1 -p observe:=true -p map_markers_file:="$map" "${common[@]}"

# autoware TrackedObjects from a best-effort publisher, in the frame odom with a static
# transform; scored samples (the objects' paths are the best by score)
FRAMES_OF=60
PUB="--type objects --best-effort --frame-id odom"
VERIFY=(--all-deleted --transform "0.5 -0.3 0.1" --warn "wrong frame:0:0" --scores --object-paths 4)
scenario tracked-objects - "$map" --map "$map" "${common[@]}" -p static_transforms:="['odom 0.5 -0.3 0.1']" \
  -p scores:=true -p object_paths:=4

# People in a frame without a transform: skipped, with a rate-limited warning
FRAMES_OF=25
PUB="--frame-id odom --best-effort"
VERIFY=(--expect-skipped --warn "wrong frame:1:6")
scenario wrong-frame - "$map" --map "$map" "${common[@]}"

# a tracker restart: its stamps jump back by 1000 s halfway; the tracks reset, no crash
FRAMES_OF=60
PUB="--stamp-base 1000 --restart-at 30 --restart-base 0 --best-effort"
VERIFY=(--all-deleted --warn "clock jumped back:1:1")
scenario tracker-restart - "$map" --map "$map" "${common[@]}"
# the installed package, started as its launch file starts it (ros2 launch cliff_ros2
# cliff.launch.py map:=...): cliffd from lib/cliff_ros2 serving the map argument, the node
# from lib/cliff_ros2 with the installed parameters file, then the launch file's own
# parameters (a file of launch_ros's shape)
launch_params="$ros2/.ws/launch_params.yaml"
printf '/**:\n  ros__parameters:\n    map_file: ""\n    daemon_map: thor1\n    map_markers_file: %s\n    rate: 0.0\n    track_timeout: 1.8\n    warn_period: 2.0\n' \
  "$map" >"$launch_params"
export CLIFF_BIN="$prefix/lib/cliff_ros2"
FRAMES_OF=40
VERIFY=(--all-deleted)
scenario package "--map thor1=$map" thor1 --ros-args -r __node:=cliff_ros2 \
  --params-file "$share/config/cliff.yaml" --params-file "$launch_params"
unset CLIFF_BIN
finish
