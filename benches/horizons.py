#!/usr/bin/env python3
"""`improved` against the motion model alone, constant velocity and the paper at every
horizon, on held-out data, with the right map and with a wrong one (the tables of
docs/accuracy.md, "Every horizon").

Runs `cliff eval --methods cliff,improved,cvm,motion` (`cliff` is the paper's method,
`motion` the built-in motion model alone, no map) on

* THÖR1 and THÖR3: round 2's people, the shipped maps (built from round 1), 12 s;
* THÖR-MAGNI: windows over the recording's last 8 minutes, a map from its first 8
  (`cliff map build --time-until 480 --grid 0.5 --radius 0.5`), 12 s and the challenge
  setting (4.8 s);
* ATC: atc/dev (the odd hours), a map from atc/train only, 50 s;

each with its right map and with the same map turned 90 degrees (every component's
direction; a map that is wrong everywhere, written as CSV, so without the speed prior a
snapshot keeps), and, for the ablation (right maps), `--methods cliff` with the
preset's options less one part. Every person counts at every horizon (a sample that
stopped counts where it stopped, `cliff eval`'s default), and every comparison is
paired over the same people (windows). Prints Markdown tables:

1. per data set and map, improved's mean ADE and FDE as a share of the motion model's:
   the largest over every horizon; of constant velocity's and the paper's at some
   horizons; the top-1 (best-ranked) sample against the motion model's and constant
   velocity's; the reach of the paper's method (improved reaches every horizon);
2. the ablation: the same figures for the preset less each of its parts.

    python3 benches/horizons.py [--cliff target/release/cliff] [--seeds 10] [--out DIR] [--no-ablation]

About ten minutes on two cores (the ATC map build and the ATC runs take most).
The summaries it writes (DIR/<data>/summary.csv) draw with `cliff plot curves`.
Standard library only.
"""

import argparse
import csv
import glob
import os
import subprocess
import sys

# the map's rows, read, turned and written as the benchmark's table does them
from tracklets import map_rows, turned, write_map

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data")

# the preset's parts as `cliff eval` options (cliff::predict::preset::IMPROVED)
PARTS = {
    "beta": ["--beta", "2"],
    "follow": ["--follow", "4"],
    "candidates": ["--candidates", "2", "--prune"],
    "speed prior": ["--speed-prior"],
    "trust": ["--trust", "0.5"],
    "blend": ["--blend", "3"],
    "consensus": ["--rank", "consensus"],
    "motion": ["--motion"],
}
# (label, parts left out, extra options)
ABLATION = [
    ("`improved`", [], []),
    ("without the motion model (`--motion`)", ["motion"], []),
    ("without trust", ["trust"], []),
    ("without blend", ["blend"], []),
    ("ranked by likelihood", ["consensus"], []),
    ("without follow", ["follow"], []),
    ("without candidates", ["candidates"], []),
    ("without the speed prior", ["speed prior"], []),
    ("with the paper's beta 1", ["beta"], []),
]
# where the long-range comparisons with the paper are made
LONG = {"thor1": [4.0, 12.0], "thor3": [4.0, 12.0], "magni-4.8": [4.8], "magni-12": [12.0], "atc": [5.0, 20.0, 50.0]}
SHOW = {
    "thor1": [0.4, 0.8, 2.0, 4.0, 8.0, 12.0],
    "thor3": [0.4, 0.8, 2.0, 4.0, 8.0, 12.0],
    "magni-4.8": [0.4, 0.8, 2.0, 3.2, 4.8],
    "magni-12": [0.4, 0.8, 2.0, 4.0, 8.0, 12.0],
    "atc": [1.0, 2.0, 5.0, 10.0, 20.0, 50.0],
}


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stderr}")
    return r.stdout


def eval_args(data, maps, turned=False):
    pick = lambda key: maps[key + " turned"] if turned else maps[key]
    thor = lambda n: ["--map", pick(f"thor{n}"), "--tracks", f"{DATA}/thor{n}/exp-{n}-run-2.csv",
                      "--format", "thor", "--protocol", "reference", "--obs", "3.2", "--dt", "0.4",
                      "--horizon", "12", "--radius", "0.7071"]
    magni = lambda h: ["--map", pick("magni"), "--tracks", f"{DATA}/magni/magni-A-first-16min.csv", "--format",
                       "magni", "--time-from", "480", "--protocol", "windows", "--obs", "3.2", "--dt", "0.4",
                       "--horizon", h, "--window-every", "4"]
    return {
        "thor1": thor(1),
        "thor3": thor(3),
        "magni-4.8": magni("4.8"),
        "magni-12": magni("12"),
        "atc": ["--map", pick("atc"), "--tracks", *sorted(glob.glob(f"{DATA}/atc/dev/*.csv")), "--format", "atc",
                "--protocol", "seconds", "--dt", "1", "--horizon", "50", "--radius", "1"],
    }[data]


def load(path):
    rows = {}
    with open(path) as f:
        for r in csv.DictReader(f):
            key = (r["person_id"], r.get("window", ""))
            rows[(r["method"], round(float(r["horizon"]), 3), key)] = r
    return rows


def paired(rows, a, b, h, col):
    """Mean of `col` of methods a and b over the people both have at horizon h."""
    h = round(h, 3)
    ka = {k[2] for k in rows if k[0] == a and k[1] == h}
    kb = {k[2] for k in rows if k[0] == b and k[1] == h}
    keys = ka & kb
    if not keys:
        return None
    mean = lambda m: sum(float(rows[(m, h, k)][col]) for k in keys) / len(keys)
    return mean(a), mean(b), len(keys)


def ratio(rows, a, b, h, col="ade"):
    p = paired(rows, a, b, h, col)
    return p[0] / p[1] if p else float("nan")


def worst_vs(rows, method, base="motion"):
    """The largest ratio of `method`'s mean ADE or FDE to `base`'s over every horizon."""
    hs = sorted({k[1] for k in rows if k[0] == method})
    worst = (0.0, "")
    for h in hs:
        for col in ("ade", "fde"):
            r = ratio(rows, method, base, h, col)
            if r > worst[0]:
                worst = (r, f"{h:g} s {col.upper()}")
    return worst


def reach(summary, method, h):
    with open(summary) as f:
        for r in csv.DictReader(f):
            if r["method"] == method and abs(float(r["horizon"]) - h) < 1e-6:
                return float(r["reach"])
    return float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cliff", default=os.path.join(ROOT, "target", "release", "cliff"))
    ap.add_argument("--seeds", default="10")
    ap.add_argument("--out", default=os.path.join(ROOT, "target", "horizons"))
    ap.add_argument("--no-ablation", action="store_true", help="the first table only (about a fifth of the time)")
    a = ap.parse_args()
    ablation = ABLATION[:1] if a.no_ablation else ABLATION
    os.makedirs(a.out, exist_ok=True)
    maps = {"magni": os.path.join(a.out, "magni-first8.cliff"), "atc": os.path.join(a.out, "atc-train.cliff"),
            "thor1": f"{DATA}/thor1/cliffmap.csv", "thor3": f"{DATA}/thor3/cliffmap.csv"}
    magni_build = ["--tracks", f"{DATA}/magni/magni-A-first-16min.csv", "--format", "magni",
                   "--time-until", "480", "--grid", "0.5", "--radius", "0.5"]
    atc_build = ["--tracks", *sorted(glob.glob(f"{DATA}/atc/train/*.csv")), "--format", "atc",
                 "--grid", "1", "--radius", "1"]
    for key, build in (("magni", magni_build), ("atc", atc_build)):
        # the snapshot (with its speed prior) and the CSV to turn
        for path in (maps[key], maps[key][:-len(".cliff")] + ".csv"):
            if not os.path.exists(path):
                run([a.cliff, "map", "build", *build, "--out", path])
    for key in ("thor1", "thor3", "magni", "atc"):
        csv_map = maps[key] if maps[key].endswith(".csv") else maps[key][:-len(".cliff")] + ".csv"
        maps[key + " turned"] = os.path.join(a.out, f"{key}-turned90.csv")
        write_map(maps[key + " turned"], turned(map_rows(csv_map), 90.0))
    results = {}
    turned_results = {}
    for data in LONG:
        out = os.path.join(a.out, data)
        run([a.cliff, "eval", *eval_args(data, maps), "--seeds", a.seeds, "--methods", "cliff,improved,cvm,motion",
             "--out", out])
        results[data] = load(os.path.join(out, "per_person.csv"))
        tout = os.path.join(a.out, data + "-turned")
        run([a.cliff, "eval", *eval_args(data, maps, turned=True), "--seeds", a.seeds,
             "--methods", "cliff,improved,cvm,motion", "--out", tout])
        turned_results[data] = (load(os.path.join(tout, "per_person.csv")), os.path.join(tout, "summary.csv"))
        for i, (label, left_out, extra) in enumerate(ablation[1:], 1):
            opts = [o for p, v in PARTS.items() if p not in left_out for o in v] + extra
            vout = os.path.join(a.out, f"{data}-variant-{i}")
            run([a.cliff, "eval", *eval_args(data, maps), "--seeds", a.seeds, "--methods", "cliff,cvm", *opts,
                 "--out", vout])
            rows = load(os.path.join(vout, "per_person.csv"))
            # the variant as method "variant", beside this data set's paper and cvm
            for (m, h, k), r in rows.items():
                if m == "cliff":
                    results[data][(label, h, k)] = r
            results[data][("summary", label)] = os.path.join(vout, "summary.csv")

    print("| data, map | worst mean ADE or FDE / motion model's | / constant velocity's | / the paper's | "
          "top-1 ADE / FDE vs the motion model's, vs constant velocity's | reach of the paper's |")
    print("|---|---|---|---|---|---|")
    for data in LONG:
        for label, rows, summary in (("right", results[data], os.path.join(a.out, data, "summary.csv")),
                                     ("turned 90°", *turned_results[data])):
            w, where = worst_vs(rows, "improved")
            shown = ", ".join(f"{h:g} s {ratio(rows, 'improved', 'cvm', h):.3f}" for h in SHOW[data])
            long = ", ".join(f"{h:g} s {ratio(rows, 'improved', 'cliff', h):.3f}" for h in LONG[data])
            h = LONG[data][-1]
            top = (f"{ratio(rows, 'improved', 'motion', h, 'top1_ade'):.3f} / "
                   f"{ratio(rows, 'improved', 'motion', h, 'top1_fde'):.3f}, "
                   f"{ratio(rows, 'improved', 'cvm', h, 'top1_ade'):.3f} / "
                   f"{ratio(rows, 'improved', 'cvm', h, 'top1_fde'):.3f} at {h:g} s")
            rc = f"{reach(summary, 'cliff', h):.0%} at {h:g} s"
            print(f"| {data}, {label} | {w:.3f} at {where} | {shown} | {long} | {top} | {rc} |")

    print()
    print("| variant | worst / the motion model (all data, right maps) | THÖR1 4 s / cvm | "
          "MAGNI 4.8 s / cvm (top-1 ADE / FDE) | MAGNI 12 s / paper | ATC 5 / 20 / 50 s / paper | ATC reach 50 s |")
    print("|---|---|---|---|---|---|---|")
    for label, _, _ in ablation:
        m = "improved" if label == "`improved`" else label
        worst = max((worst_vs(rows, m) + (d,) for d, rows in results.items()), key=lambda x: x[0])
        r = results
        atc = " / ".join(f"{ratio(r['atc'], m, 'cliff', h):.3f}" for h in (5.0, 20.0, 50.0))
        summary = os.path.join(a.out, "atc", "summary.csv") if m == "improved" else r["atc"][("summary", label)]
        rc = reach(summary, "improved" if m == "improved" else "cliff", 50.0)
        print(f"| {label} | {worst[0]:.3f} ({worst[2]} {worst[1]}) | {ratio(r['thor1'], m, 'cvm', 4.0):.3f} | "
              f"{ratio(r['magni-4.8'], m, 'cvm', 4.8):.3f} ({ratio(r['magni-4.8'], m, 'cvm', 4.8, 'top1_ade'):.3f} / "
              f"{ratio(r['magni-4.8'], m, 'cvm', 4.8, 'top1_fde'):.3f}) | {ratio(r['magni-12'], m, 'cliff', 12.0):.3f} | "
              f"{atc} | {rc:.0%} |")


if __name__ == "__main__":
    main()
