#!/usr/bin/env python3
"""The THÖR-MAGNI benchmark's protocol on the recording beside the project: every method
with the right map, wrong maps and no map (the tables of docs/accuracy.md, "Where the
map is wrong, thin or missing").

Tracklets as the public benchmark cuts them (tmralmeida/lhmp-thor-magni-challenge-extras:
20 rows at 0.4 s back to back along each helmet's contiguous tracking, rows 1-8 observed,
9-20 predicted, one top-1 prediction per tracklet) from the last 16 minutes of
../shared/data/magni/magni-A.csv; the map (`cliff map build`, grid and radius 0.5 m) and
the site's motion model (`cliff motion fit`) from its first 16 minutes only. Every
tracklet counts at every horizon (a sample that stopped counts where it stopped), 10
seeds. The maps:

  right      built from the first 16 minutes
  turned 60  the same map with every direction turned 60 degrees (a map that is wrong)
  turned 90  turned 90 degrees
  THÖR1      the map of another room (../shared/data/thor1/cliffmap.csv)
  none       the right map moved 1 km away (no location near anyone)

    python3 benches/tracklets.py [--cliff target/release/cliff] [--seeds 10] [--out DIR]
                                 [--max-speed 3]

(--max-speed: leave out tracklets with a step faster than this, tracking jumps, as the
benchmark leaves out tracklets outside its speed bounds; 0 keeps every tracklet.)
Prints Markdown tables: top-1 ADE and FDE at 4.8 s per method and map, and each
method's ratio to constant velocity of the last displacement; the row `improved`
without the motion model is `improved`'s preset as options without `--motion` (the map's
samples from constant velocity, stopping where the map has no data). Standard library
only.
"""

import argparse
import csv
import math
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data")
MAGNI = os.path.join(DATA, "magni", "magni-A.csv")
METHODS = ["cliff", "improved", "cvm", "cvm-last", "motion"]
# `improved`'s preset as options, without the motion model under the map (`--motion`)
IMPROVED_ALONE = ["--beta", "2", "--follow", "4", "--candidates", "2", "--prune",
                  "--speed-prior", "--trust", "0.5", "--blend", "3", "--rank", "consensus"]
WITHOUT_MOTION = "improved without the motion model"
HORIZON = 4.8


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stderr}")
    return r.stdout


def map_rows(path):
    with open(path) as f:
        return [[float(v) for v in row] for row in csv.reader(f) if row]


def write_map(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        for r in rows:
            w.writerow([repr(v) for v in r])


def turned(rows, degrees):
    out = []
    for r in rows:
        r = list(r)
        r[2] = (r[2] + math.radians(degrees)) % (2 * math.pi)
        out.append(r)
    return out


def moved(rows, dx):
    return [[r[0] + dx, r[1] + dx] + r[2:] for r in rows]


def summary(path):
    with open(path) as f:
        return {(r["method"], float(r["horizon"])): r for r in csv.DictReader(f)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cliff", default=os.path.join(ROOT, "target", "release", "cliff"))
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--out", default=os.path.join(ROOT, "target", "bench-tracklets"))
    ap.add_argument("--max-speed", type=float, default=3.0)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    cliff = a.cliff
    first = ["--tracks", MAGNI, "--format", "magni", "--time-until", "960"]
    right = os.path.join(a.out, "magni16.csv")
    run([cliff, "map", "build", *first, "--grid", "0.5", "--radius", "0.5", "--out", right])
    # the speed prior lives in snapshots: the .cliff keeps it for `improved`
    right_snapshot = os.path.join(a.out, "magni16.cliff")
    run([cliff, "map", "build", *first, "--grid", "0.5", "--radius", "0.5", "--out", right_snapshot])
    model = os.path.join(a.out, "magni16.motion")
    run([cliff, "motion", "fit", *first, "--validation", "0", "--out", model])
    rows = map_rows(right)
    maps = [("right", right_snapshot)]
    for deg in (60, 90):
        p = os.path.join(a.out, f"turned{deg}.csv")
        write_map(p, turned(rows, deg))
        maps.append((f"turned {deg}", p))
    maps.append(("THÖR1", os.path.join(DATA, "thor1", "cliffmap.csv")))
    p = os.path.join(a.out, "none.csv")
    write_map(p, moved(rows, 1000.0))
    maps.append(("none", p))

    speed = ["--max-speed", str(a.max_speed)] if a.max_speed > 0 else []
    results = {}
    people = None
    for label, path in maps:
        out = os.path.join(a.out, label.replace(" ", ""))
        run([cliff, "eval", "--map", path, "--tracks", MAGNI, "--format", "magni",
             "--time-from", "960", "--protocol", "tracklets", "--obs-rows", "8",
             "--pred-rows", "12", "--dt", "0.4", "--radius", "0.5", "--seeds", str(a.seeds),
             "--count", "everyone", "--motion-model", model, "--methods", ",".join(METHODS),
             *speed, "--out", out])
        s = summary(os.path.join(out, "summary.csv"))
        run([cliff, "eval", "--map", path, "--tracks", MAGNI, "--format", "magni",
             "--time-from", "960", "--protocol", "tracklets", "--obs-rows", "8",
             "--pred-rows", "12", "--dt", "0.4", "--radius", "0.5", "--seeds", str(a.seeds),
             "--count", "everyone", "--motion-model", model, "--methods", "cliff",
             *IMPROVED_ALONE, *speed, "--out", out + "-motion"])
        m = summary(os.path.join(out + "-motion", "summary.csv"))
        s[(WITHOUT_MOTION, HORIZON)] = m[("cliff", HORIZON)]
        results[label] = s
        people = s[("cvm-last", HORIZON)]["people"]

    print(f"{people} tracklets, top-1 ADE / FDE at {HORIZON} s (m); "
          f"ratio to cvm-last in brackets; reach of the paper's method")
    print()
    print("| method | " + " | ".join(label for label, _ in maps) + " |")
    print("|---|" + "---|" * len(maps))
    for m in METHODS[:2] + [WITHOUT_MOTION] + METHODS[2:]:
        cells = []
        for label, _ in maps:
            r = results[label][(m, HORIZON)]
            base = results[label][("cvm-last", HORIZON)]
            ade, fde = float(r["top1_ade"]), float(r["top1_fde"])
            ra, rf = ade / float(base["top1_ade"]), fde / float(base["top1_fde"])
            cells.append(f"{ade:.3f} / {fde:.3f} ({ra:.2f} / {rf:.2f})")
        print(f"| `{m}` | " + " | ".join(cells) + " |")
    reach = [f"{float(results[label][('cliff', HORIZON)]['reach']):.0%}" for label, _ in maps]
    print("| reach of `cliff` | " + " | ".join(reach) + " |")


if __name__ == "__main__":
    main()
