#!/usr/bin/env bash
# A site with many robots on one host (docs/zenoh.md, "A site with many robots"): a site
# cliffd learning the ATC map over zenoh on loopback, a robot cliffd following it
# (--follow) in another iceoryx2 namespace. Prints the JSON lines of
# service/benches/site_follow.rs: observation rows per second from one remote session,
# the delay from a site version to the robot serving it, and the robot's round trips
# (p50, p99) while nothing arrives and while versions arrive.
#
#   benches/site_follow.sh                       # 5 s phases, the follow phase 20 s
#   SECONDS_PER_PHASE=10 FOLLOW_EVERY_MS=100 benches/site_follow.sh
#
# Builds cliffd and the bench with the zenoh feature (release). Port 27483. Needs both
# cores: close other work. Not in CI.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p cliff-service --features zenoh --bin cliffd
SECONDS="${SECONDS_PER_PHASE:-5}" FOLLOW_EVERY_MS="${FOLLOW_EVERY_MS:-500}" CLIFFD="$PWD/target/release/cliffd" \
    cargo bench -q -p cliff-service --features zenoh --bench site_follow
