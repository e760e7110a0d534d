#!/usr/bin/env python3
"""`improved` against constant velocity and the paper at every horizon, on held-out data
(the tables of docs/accuracy.md, "Every horizon").

Runs `cliff eval --methods cliff,improved,cvm` (`cliff` is the paper's method) on

* THÖR1 and THÖR3: round 2's people, the shipped maps (built from round 1), 12 s;
* THÖR-MAGNI: windows over the recording's last 8 minutes, a map from its first 8
  (`cliff map build --time-until 480 --grid 0.5 --radius 0.5`), 12 s and the challenge
  setting (4.8 s);
* ATC: atc/dev (the odd hours), a map from atc/train only, 50 s;

and, for the ablation, `--methods cliff` with the preset's options less one part. Every
comparison is paired: means over the people (windows) that both methods predict at that
horizon. Prints Markdown tables:

1. per data set, improved's mean ADE and FDE as a share of constant velocity's: the
   largest over every horizon after the first step, and at some horizons; and of the
   paper's at the long horizons; the top-1 (best-ranked) sample against constant
   velocity; the reach (share of people a prediction reaches) of improved and the paper;
2. the ablation: the same figures for the preset less each of its parts.

    python3 benches/horizons.py [--cliff target/release/cliff] [--seeds 10] [--out DIR] [--no-ablation]

About five minutes on two cores (the ATC map build and the ATC runs take most).
The summaries it writes (DIR/<data>/summary.csv) draw with `cliff plot curves`.
Standard library only.
"""

import argparse
import csv
import glob
import os
import subprocess
import sys

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
}
# (label, parts left out, extra options)
ABLATION = [
    ("`improved`", [], []),
    ("without trust", ["trust"], []),
    ("without blend", ["blend"], []),
    ("ranked by likelihood", ["consensus"], []),
    ("without follow", ["follow"], []),
    ("without candidates", ["candidates"], []),
    ("without the speed prior", ["speed prior"], []),
    ("with the paper's beta 1", ["beta"], []),
    ("without trust, blend and consensus (the earlier preset)", ["trust", "blend", "consensus"], []),
    ("with `--coast 50` (every sample reaches the horizon)", [], ["--coast", "50"]),
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


def eval_args(data, maps):
    thor = lambda n: ["--map", f"{DATA}/thor{n}/cliffmap.csv", "--tracks", f"{DATA}/thor{n}/exp-{n}-run-2.csv",
                      "--format", "thor", "--protocol", "reference", "--obs", "3.2", "--dt", "0.4",
                      "--horizon", "12", "--radius", "0.7071"]
    magni = lambda h: ["--map", maps["magni"], "--tracks", f"{DATA}/magni/magni-A-first-16min.csv", "--format",
                       "magni", "--time-from", "480", "--protocol", "windows", "--obs", "3.2", "--dt", "0.4",
                       "--horizon", h, "--window-every", "4"]
    return {
        "thor1": thor(1),
        "thor3": thor(3),
        "magni-4.8": magni("4.8"),
        "magni-12": magni("12"),
        "atc": ["--map", maps["atc"], "--tracks", *sorted(glob.glob(f"{DATA}/atc/dev/*.csv")), "--format", "atc",
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


def worst_vs_cvm(rows, method):
    hs = sorted({k[1] for k in rows if k[0] == method})
    worst = (0.0, "")
    for h in hs[1:]:
        for col in ("ade", "fde"):
            r = ratio(rows, method, "cvm", h, col)
            if r > worst[0]:
                worst = (r, f"{h:g} s {col.upper()}")
    first = max(ratio(rows, method, "cvm", hs[0], c) for c in ("ade", "fde"))
    return worst, first


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
    maps = {"magni": os.path.join(a.out, "magni-first8.cliff"), "atc": os.path.join(a.out, "atc-train.cliff")}
    if not os.path.exists(maps["magni"]):
        run([a.cliff, "map", "build", "--tracks", f"{DATA}/magni/magni-A-first-16min.csv", "--format", "magni",
             "--time-until", "480", "--grid", "0.5", "--radius", "0.5", "--out", maps["magni"]])
    if not os.path.exists(maps["atc"]):
        run([a.cliff, "map", "build", "--tracks", *sorted(glob.glob(f"{DATA}/atc/train/*.csv")), "--format", "atc",
             "--grid", "1", "--radius", "1", "--out", maps["atc"]])
    results = {}
    for data in LONG:
        out = os.path.join(a.out, data)
        run([a.cliff, "eval", *eval_args(data, maps), "--seeds", a.seeds, "--methods", "cliff,improved,cvm",
             "--out", out])
        results[data] = load(os.path.join(out, "per_person.csv"))
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

    print("| data | worst ADE or FDE / constant velocity's (first step) | "
          "at the horizons shown | / the paper's | top-1 ADE / FDE vs constant velocity | reach: improved, paper |")
    print("|---|---|---|---|---|---|")
    for data, rows in results.items():
        (w, where), first = worst_vs_cvm(rows, "improved")
        shown = ", ".join(f"{h:g} s {ratio(rows, 'improved', 'cvm', h):.3f}" for h in SHOW[data])
        long = ", ".join(f"{h:g} s {ratio(rows, 'improved', 'cliff', h):.3f}" for h in LONG[data])
        h = LONG[data][-1]
        top = f"{ratio(rows, 'improved', 'cvm', h, 'top1_ade'):.3f} / {ratio(rows, 'improved', 'cvm', h, 'top1_fde'):.3f} at {h:g} s"
        summary = os.path.join(a.out, data, "summary.csv")
        rc = f"{reach(summary, 'improved', h):.0%}, {reach(summary, 'cliff', h):.0%} at {h:g} s"
        print(f"| {data} | {w:.3f} at {where} ({first:.4f}) | {shown} | {long} | {top} | {rc} |")

    print()
    print("| variant | worst / constant velocity (all data, after the first step) | THÖR1 4 s / cvm | "
          "MAGNI 4.8 s / cvm (top-1 ADE / FDE) | MAGNI 12 s / paper | ATC 5 / 20 / 50 s / paper | ATC reach 50 s |")
    print("|---|---|---|---|---|---|---|")
    for label, _, _ in ablation:
        m = "improved" if label == "`improved`" else label
        worst = max((worst_vs_cvm(rows, m)[0] + (d,) for d, rows in results.items()), key=lambda x: x[0])
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
