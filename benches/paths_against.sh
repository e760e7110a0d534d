#!/usr/bin/env bash
# The paper's method on both instruction paths, against an earlier commit's baseline
# path, in one run: builds `benches/options_cost.rs` of COMMIT (default cfd058e, the
# lane loop before the per-sample generators) in a worktree of its own (the core crate
# only, its own target directory), builds the current one, then runs the two binaries
# alternately, RUNS times each (default 3), and prints per case the median over the
# runs of each run's median time per call, and each case's ratio to the old binary's
# baseline case (`x old baseline`: how many times faster).
#
# Run from the repository root: `benches/paths_against.sh [COMMIT] [RUNS] [ROUNDS]`
# (ROUNDS: rounds of 20 calls per case in one run, default 100). The datasets are read
# from ../shared/data, as the benches do.
set -euo pipefail

commit=${1:-cfd058e}
runs=${2:-3}
rounds=${3:-100}
root=$(pwd)
old_tree=${OLD_TREE:-/tmp/cliff-paths-$commit}
old_target=${OLD_TARGET:-/tmp/cliff-paths-$commit-target}

bench_binary() {
    # the options_cost binary `cargo bench --no-run` builds, from its JSON messages
    cargo bench -p cliff --bench options_cost --no-run --message-format=json 2>/dev/null |
        python3 -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "options_cost" and m.get("executable"):
        print(m["executable"])'
}

if [ ! -d "$old_tree" ]; then
    git worktree add --detach "$old_tree" "$commit" >/dev/null
fi
# (the old tree reads ../shared/data beside it, as this one does)
[ -e "$(dirname "$old_tree")/shared" ] || ln -s "$(cd .. && pwd)/shared" "$(dirname "$old_tree")/shared"
old=$(cd "$old_tree" && CARGO_TARGET_DIR=$old_target bench_binary)
new=$(bench_binary)
echo "old ($commit): $old"
echo "new ($(git -C "$root" rev-parse --short HEAD)): $new"
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(nproc) cpus; $(date -u '+%F %H:%M UTC'); load $(cut -d' ' -f1-3 /proc/loadavg)"

results=$(mktemp)
for run in $(seq "$runs"); do
    for which in old new; do
        bin=$old
        [ "$which" = new ] && bin=$new
        # the default case alone, both paths, both people
        (cd "$([ "$which" = old ] && echo "$old_tree" || echo "$root")" && "$bin" "$rounds" 20 none) |
            awk -v w="$which" -v r="$run" '/_default/ {print w, r, $1, $2}' >>"$results"
    done
done
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
python3 - "$results" <<'EOF'
import statistics, sys
rows = [l.split() for l in open(sys.argv[1])]
cases = {}
for which, run, case, us in rows:
    cases.setdefault((which, case), []).append(float(us))
base = {}
for (which, case), v in cases.items():
    if which == "old" and not case.endswith("_avx2"):
        base[case] = statistics.median(v)
print(f"{'binary':<5} {'case':<44} {'median us':>10} {'x old baseline':>15}   runs")
for (which, case), v in sorted(cases.items(), key=lambda kv: (kv[0][1].split('_')[0], kv[0][0] != 'old', kv[0][1])):
    person = case.removesuffix("_avx2")
    m = statistics.median(v)
    print(f"{which:<5} {case:<44} {m:>10.2f} {base[person] / m:>15.2f}   {' '.join(f'{x:.2f}' for x in v)}")
EOF
rm -f "$results"
