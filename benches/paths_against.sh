#!/usr/bin/env bash
# The paper's method on both instruction paths, against an earlier commit's baseline
# path, in one run: builds `benches/options_cost.rs` of COMMIT (default cfd058e, the
# lane loop before the per-sample generators) in a worktree of its own (the core crate
# only, its own target directory), builds the current one, then runs the two binaries
# alternately, RUNS times each (default 3), and prints per case the median over the
# runs of each run's median time per call, each case's ratio to the old binary's
# baseline case of the same person in the same run (`x old baseline`: how many times
# faster; the median over runs, and per run), and which run is the median one.
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
times = {}  # (binary, case) -> {run: us}
for which, run, case, us in rows:
    times.setdefault((which, case), {})[int(run)] = float(us)
runs = sorted({int(r[1]) for r in rows})
def person(case):
    return case.removesuffix("_avx2")
def ratio(which, case, run):
    # times faster than the old binary's baseline case of this person, in the same run
    return times[("old", person(case))][run] / times[(which, case)][run]
print(f"{'binary':<5} {'case':<40} {'median us':>9} {'x old baseline':>14}   per run (us, x)")
order = sorted(times, key=lambda k: (person(k[1]), k[0] != "old", k[1]))
for which, case in order:
    t = times[(which, case)]
    xs = [ratio(which, case, r) for r in runs]
    per = "  ".join(f"{t[r]:.2f} {x:.2f}" for r, x in zip(runs, xs))
    print(f"{which:<5} {case:<40} {statistics.median(t.values()):>9.2f} {statistics.median(xs):>14.2f}   {per}")
# the median run: the run whose ratio (new AVX2 to old baseline, both people) is the median
score = {r: statistics.mean(ratio("new", c, r) for (w, c) in times if w == "new" and c.endswith("_avx2")) for r in runs}
median_run = sorted(runs, key=lambda r: score[r])[len(runs) // 2]
print(f"median run: {median_run} (mean of the AVX2 cases' ratios per run: "
      + ", ".join(f"{r}: {score[r]:.2f}" for r in runs) + ")")
EOF
rm -f "$results"
