#!/usr/bin/env python3
"""Held-out evidence for `improved` and its parts (the tables of docs/accuracy.md).

Runs `cliff eval` on atc/dev (the odd hours) with maps built from atc/train only, every
variant on the same people with the same seeds, and prints a Markdown table: mean ADE
and top-1 ADE (m) at 5, 20 and 50 s, and the ratio of each variant's mean ADE to the
paper's over the people both predict at that horizon (paired, lower is better).

    python3 benches/beyond.py [--cliff target/release/cliff] [--seeds 10] [--out DIR] [--only 0,1]

(--only: the rows to run, by their index in VARIANTS; the paper's row 0 is always run.)

Builds the two maps it needs in --out first (about a minute on two cores): the all-day
map with its speed prior (`cliff map build` defaults) and a time-of-day set (1 h
slices, clock offset 9 h: ATC stores unix time, Osaka is UTC+9). Standard library only.
"""

import argparse
import csv
import glob
import os
import subprocess
import sys

HORIZONS = (5.0, 20.0, 50.0)
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data", "atc")

# (label, map, method, extra options)
VARIANTS = [
    ("paper (`cliff`)", "day", "cliff", []),
    ("**`improved`**", "day", "improved", []),
    ("`improved` on the time-of-day set", "set", "improved", []),
    ("beta 2 alone", "day", "cliff", ["--beta", "2"]),
    ("follow 4 alone", "day", "cliff", ["--follow", "4"]),
    ("5 candidates alone (ranked samples)", "day", "cliff", ["--candidates", "5"]),
    ("speed prior alone", "day", "cliff", ["--speed-prior"]),
    ("time-of-day set alone", "set", "cliff", []),
    ("coasting 10 s alone", "day", "cliff", ["--coast", "10"]),
    ("speed kernel 4 alone", "day", "cliff", ["--speed-beta", "4"]),
    # the earlier preset (before trust, blend and consensus ranking) and it less one part;
    # the current preset's parts: benches/horizons.py
    ("the earlier `improved`", "day", "cliff", ["--beta", "2", "--follow", "4", "--candidates", "5", "--speed-prior"]),
    ("the earlier `improved` with the paper's beta 1", "day", "cliff", ["--follow", "4", "--candidates", "5", "--speed-prior"]),
    ("the earlier `improved` without follow", "day", "cliff", ["--beta", "2", "--candidates", "5", "--speed-prior"]),
    ("the earlier `improved` without candidates", "day", "cliff", ["--beta", "2", "--follow", "4", "--speed-prior"]),
    ("the earlier `improved` without the speed prior", "day", "cliff", ["--beta", "2", "--follow", "4", "--candidates", "5"]),
]


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stderr}")
    return r.stdout


def per_person(path, method):
    out = {}
    with open(path) as f:
        for row in csv.DictReader(f):
            if row["method"] == method and float(row["horizon"]) in HORIZONS:
                out[(row["person_id"], float(row["horizon"]))] = (
                    float(row["ade"]),
                    float(row["top1_ade"]),
                )
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cliff", default=os.path.join(ROOT, "target", "release", "cliff"))
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--out", default="/tmp/cliff-beyond")
    ap.add_argument("--only", default="", help="comma-separated row indices (the paper's row 0 is always run)")
    a = ap.parse_args()
    only = {0} | {int(i) for i in a.only.split(",") if i.strip()} if a.only else None
    os.makedirs(a.out, exist_ok=True)
    train = sorted(glob.glob(os.path.join(DATA, "train", "*.csv")))
    dev = sorted(glob.glob(os.path.join(DATA, "dev", "*.csv")))
    maps = {"day": os.path.join(a.out, "atc-train.cliff"), "set": os.path.join(a.out, "atc-train-1h.cliff")}
    base = [a.cliff, "map", "build", "--tracks", *train, "--format", "atc", "--grid", "1", "--radius", "1", "--quiet"]
    if not os.path.exists(maps["day"]):
        run(base + ["--out", maps["day"]])
    if not os.path.exists(maps["set"]):
        run(base + ["--slice", "1h", "--clock-offset", "9h", "--out", maps["set"]])
    results = []
    for i, (label, m, method, extra) in enumerate(VARIANTS):
        if only is not None and i not in only:
            continue
        d = os.path.join(a.out, f"v{i}")
        run([a.cliff, "eval", "--map", maps[m], "--tracks", *dev, "--format", "atc", "--protocol", "seconds",
             "--dt", "1", "--horizon", "50", "--radius", "1", "--seeds", str(a.seeds), "--methods", method,
             "--full-horizon-only", *extra, "--out", d])
        results.append((label, method, extra, m, per_person(os.path.join(d, "per_person.csv"), method)))
    paper = results[0][4]
    print("| variant | options | " + " | ".join(f"ADE {h:g} s (ratio) | top-1 {h:g} s" for h in HORIZONS) + " |")
    print("|---|---|" + "---|---|" * len(HORIZONS))
    for label, method, extra, m, pp in results:
        cells = []
        for h in HORIZONS:
            keys = [k for k in pp if k[1] == h]
            both = [k for k in keys if k in paper]
            ade = sum(pp[k][0] for k in keys) / len(keys)
            top1 = sum(pp[k][1] for k in keys) / len(keys)
            ratio = sum(pp[k][0] for k in both) / sum(paper[k][0] for k in both)
            cells.append(f"{ade:.3f} ({ratio:.3f}) | {top1:.3f}")
        opts = " ".join(["--methods", method, *extra]) + (" (set)" if m == "set" else "")
        print(f"| {label} | `{opts}` | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
