#!/usr/bin/env python3
"""Paired comparison of methods from one `cliff eval` run's per_person.csv.

`cliff eval` averages each method's errors over the people (or windows) that method
predicts at a horizon; a method whose samples stop earlier is averaged over fewer. This
prints, per horizon, the mean ADE and FDE of each method over the people (windows) that
every listed method predicts there, and each method's ratio to the first's.

    python3 benches/paired.py OUT/per_person.csv [--methods cliff,improved,cvm] [--horizons 4,8,12]

Standard library only.
"""

import argparse
import csv
import sys


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("per_person", help="per_person.csv written by `cliff eval --out DIR`")
    ap.add_argument("--methods", default="cliff,improved,cvm", help="the first is the reference")
    ap.add_argument("--horizons", default=None, help="seconds, comma-separated (default: every horizon)")
    a = ap.parse_args()
    methods = a.methods.split(",")
    with open(a.per_person) as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"{a.per_person}: no rows")
    horizons = (
        [float(h) for h in a.horizons.split(",")]
        if a.horizons
        else sorted({float(r["horizon"]) for r in rows})
    )
    # one row per person (and window), method and horizon
    errors = {}
    for r in rows:
        key = (r["person_id"], r.get("window", ""))
        errors[(r["method"], float(r["horizon"]), key)] = (float(r["ade"]), float(r["fde"]))
    print("| horizon | people | " + " | ".join(f"{m} ADE (ratio) | {m} FDE" for m in methods) + " |")
    print("|---|---|" + "---|---|" * len(methods))
    for h in horizons:
        keys = {k for (m, hh, k) in errors if m == methods[0] and abs(hh - h) < 1e-6}
        hkey = {m: next((hh for (mm, hh, _) in errors if mm == m and abs(hh - h) < 1e-6), None) for m in methods}
        if any(v is None for v in hkey.values()):
            continue
        both = sorted(k for k in keys if all((m, hkey[m], k) in errors for m in methods))
        if not both:
            continue
        mean = {
            m: [sum(errors[(m, hkey[m], k)][i] for k in both) / len(both) for i in (0, 1)]
            for m in methods
        }
        ref = mean[methods[0]][0]
        cells = [f"{mean[m][0]:.3f} ({mean[m][0] / ref:.3f}) | {mean[m][1]:.3f}" for m in methods]
        print(f"| {h:g} s | {len(both)} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
