#!/usr/bin/env python3
"""A daemon that learns its site, judged on held-out people (docs/learning.md's table).

Builds a map from one training hour of ATC (atc/train) and, offline, a map from all
training hours; starts `cliffd` with the one-hour map and `--learn`, streams the other
training hours to it with `cliff observe` (as robots would, faster than real time), and
keeps every snapshot it writes. Then scores each snapshot and both offline maps on
atc/dev (`cliff map score`: mean log-likelihood of the held-out people's velocities) and
runs CLiFF-LHMP (`cliff eval`, seconds protocol, the same people and seeds for each map)
with the one-hour map, the learned map and the all-hours map. Prints a Markdown table
and writes a picture of the score rising as observations arrive (SVG, standard library
only) and the curve as CSV.

    python3 benches/learning.py [--bin target/release] [--hour 10] [--seeds 10] [--out DIR]

The stream is about 1,500 times faster than real time, so the daemon's pace settings
are scaled to it (as service/tests/learning.rs does): a version every 3 s or 20,000
rows. Damping (`--learn-move-per-min`) counts wall-clock minutes, and ten hours of
observations arrive in under half a minute: at the default 0.01 per minute scaled by the
pace (x 1,500) no location's move is bound, so the run turns damping off (`inf`). The
single client streaming is trusted, as a site seeding its daemon from recordings is:
`--learn-client-share 1` (the default 0.5 would thin a lone client's rows by half) and
`--learn-track-rows 100000` (ATC's tracks at 1 Hz are long; the offline build does not
cap them either). `--learn-count-scale` is the one-hour map's busiest node, so that the
served map's counts weigh as the rows it was built from. The held-out guard stays on:
every tenth segment is not learned.
"""

import argparse
import csv
import glob
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time

HORIZONS = (20.0, 50.0)
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data", "atc")


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stderr}")
    return r.stdout


def busiest_node(build_output):
    m = re.search(r"busiest node\s+(\d+)", build_output)
    if not m:
        sys.exit("cliff map build did not print its busiest node")
    return int(m.group(1))


def score(cliff, map_path, dev):
    out = run([cliff, "map", "score", "--map", map_path, "--tracks", *dev, "--format", "atc", "--json"])
    return json.loads(out)["mean_log_likelihood"]


def ade(cliff, map_path, dev, seeds, methods, out):
    """Per (method, person, horizon): (ADE, share of the samples reaching the horizon,
    minADE, minFDE), over the people whose ground truth lasts the whole horizon."""
    os.makedirs(out, exist_ok=True)
    run([cliff, "eval", "--map", map_path, "--tracks", *dev, "--format", "atc", "--protocol", "seconds",
         "--dt", "1", "--horizon", "50", "--radius", "1", "--seeds", str(seeds), "--methods", ",".join(methods),
         "--full-horizon-only", "--out", out])
    per = {}
    with open(os.path.join(out, "per_person.csv")) as f:
        for row in csv.DictReader(f):
            if float(row["horizon"]) in HORIZONS:
                reach = float(row["samples_reaching"]) / 20.0
                per[(row["method"], row["person_id"], float(row["horizon"]))] = (
                    float(row["ade"]), reach, float(row["min_ade"]), float(row["min_fde"]))
    return per


def summary(cliff, map_path, dev, seeds, methods, out):
    """Per (method, horizon): the means over every person the seconds protocol predicts
    to that horizon (cliff eval's summary): people, ADE, minADE, minFDE."""
    os.makedirs(out, exist_ok=True)
    run([cliff, "eval", "--map", map_path, "--tracks", *dev, "--format", "atc", "--protocol", "seconds",
         "--dt", "1", "--horizon", "50", "--radius", "1", "--seeds", str(seeds), "--methods", ",".join(methods),
         "--out", out])
    got = {}
    with open(os.path.join(out, "summary.csv")) as f:
        for row in csv.DictReader(f):
            if float(row["horizon"]) in HORIZONS:
                got[(row["method"], float(row["horizon"]))] = tuple(
                    float(row[c]) for c in ("people", "ade", "min_ade", "min_fde"))
    return got


def keep_snapshots(learn_dir, snaps, stop):
    """Copy every snapshot the daemon writes (it keeps only the newest three)."""
    while True:
        done = stop.is_set()
        for path in glob.glob(os.path.join(learn_dir, "*.state")):
            name = os.path.basename(path)[: -len(".state")]
            cliff = os.path.join(learn_dir, name + ".cliff")
            if not os.path.exists(os.path.join(snaps, name + ".state")) and os.path.exists(cliff):
                try:
                    shutil.copy(cliff, snaps)
                    shutil.copy(path, snaps)
                except FileNotFoundError:
                    pass  # rotated away between the listing and the copy
        if done:
            return
        time.sleep(0.2)


def svg(points, lines, path):
    """A line chart of (rows, score) with horizontal reference lines [(label, y, colour)]."""
    w, h, left, right, top, bottom = 720, 420, 70, 20, 30, 50
    xs = [p[0] for p in points]
    ys = [p[1] for p in points] + [y for _, y, _ in lines]
    x0, x1 = 0, max(xs) or 1
    y0, y1 = min(ys), max(ys)
    pad = 0.05 * (y1 - y0 or 1)
    y0, y1 = y0 - pad, y1 + pad

    def px(x):
        return left + (x - x0) / (x1 - x0) * (w - left - right)

    def py(y):
        return top + (y1 - y) / (y1 - y0) * (h - top - bottom)

    s = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">',
         f'<rect width="{w}" height="{h}" fill="white"/>',
         f'<text x="{w / 2}" y="18" text-anchor="middle" font-size="14">Learned map\'s score on held-out ATC people (atc/dev)</text>',
         f'<line x1="{left}" y1="{h - bottom}" x2="{w - right}" y2="{h - bottom}" stroke="black"/>',
         f'<line x1="{left}" y1="{top}" x2="{left}" y2="{h - bottom}" stroke="black"/>',
         f'<text x="{w / 2}" y="{h - 12}" text-anchor="middle">rows learned (thousands)</text>',
         f'<text x="16" y="{h / 2}" text-anchor="middle" transform="rotate(-90 16 {h / 2})">mean log-likelihood</text>']
    for i in range(6):
        x = x0 + i * (x1 - x0) / 5
        s.append(f'<text x="{px(x):.1f}" y="{h - bottom + 16}" text-anchor="middle">{x / 1000:.0f}</text>')
        y = y0 + i * (y1 - y0) / 5
        s.append(f'<text x="{left - 6}" y="{py(y) + 4:.1f}" text-anchor="end">{y:.2f}</text>')
    for label, y, colour in lines:
        s.append(f'<line x1="{left}" y1="{py(y):.1f}" x2="{w - right}" y2="{py(y):.1f}" stroke="{colour}" stroke-dasharray="6 4"/>')
        s.append(f'<text x="{w - right - 4}" y="{py(y) - 5:.1f}" text-anchor="end" fill="{colour}">{label}</text>')
    pts = " ".join(f"{px(x):.1f},{py(y):.1f}" for x, y in points)
    s.append(f'<polyline points="{pts}" fill="none" stroke="#1f5fbf" stroke-width="2"/>')
    for x, y in points:
        s.append(f'<circle cx="{px(x):.1f}" cy="{py(y):.1f}" r="2.5" fill="#1f5fbf"/>')
    s.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(s) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release"), help="where cliff and cliffd are")
    ap.add_argument("--hour", default="10", help="the training hour the daemon starts from (atc-1024-HOUR_train.csv)")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--out", default="/tmp/cliff-learning")
    ap.add_argument("--methods", default="cliff,improved", help="methods whose ADE is compared (cliff eval --methods)")
    ap.add_argument("--all-people", action="store_true",
                    help="also evaluate every person the protocol predicts to each horizon, not only those with "
                         "the whole 50 s of ground truth (a third table)")
    a = ap.parse_args()
    cliff, cliffd = os.path.join(a.bin, "cliff"), os.path.join(a.bin, "cliffd")
    train = sorted(glob.glob(os.path.join(DATA, "train", "*.csv")))
    dev = sorted(glob.glob(os.path.join(DATA, "dev", "*.csv")))
    first = [p for p in train if os.path.basename(p) == f"atc-1024-{a.hour}_train.csv"]
    if not first:
        sys.exit(f"no training hour {a.hour} in {DATA}/train")
    rest = [p for p in train if p not in first]
    shutil.rmtree(a.out, ignore_errors=True)
    learn_dir, snaps = os.path.join(a.out, "learn"), os.path.join(a.out, "snapshots")
    os.makedirs(learn_dir)
    os.makedirs(snaps)

    build = [cliff, "map", "build", "--format", "atc", "--grid", "1", "--radius", "1"]
    one, every = os.path.join(a.out, "one-hour.cliff"), os.path.join(a.out, "all-hours.cliff")
    scale = busiest_node(run(build + ["--tracks", *first, "--out", one]))
    run(build + ["--tracks", *train, "--out", every])

    prefix = f"cliff-learning-{os.getpid()}"
    env = dict(os.environ, CLIFF_IPC_PREFIX=prefix)
    log = open(os.path.join(a.out, "cliffd.log"), "w")
    daemon = subprocess.Popen(
        [cliffd, "--map", f"atc={one}", "--learn", "atc", "--learn-dir", learn_dir,
         "--learn-count-scale", str(scale), "--learn-client-share", "1", "--learn-track-rows", "100000",
         "--learn-move-per-min", "inf", "--observe-rate", "20000", "--observe-rows-held", "65536",
         "--observe-tracks", "4096", "--track-timeout-s", "0.5", "--learn-every-s", "3",
         "--snapshot-every-s", "1"],
        env=env, stdout=log, stderr=subprocess.STDOUT)
    stop = threading.Event()
    copier = threading.Thread(target=keep_snapshots, args=(learn_dir, snaps, stop))
    copier.start()
    try:
        started = time.time()
        observed = subprocess.run([cliff, "observe", "--map", "atc", "--tracks", *rest, "--format", "atc",
                                   "--quiet", "--give-up-s", "30"], env=env, capture_output=True, text=True)
        if observed.returncode != 0:
            sys.exit(f"cliff observe failed:\n{observed.stderr}")
        streamed = time.time() - started
        time.sleep(4)  # the last rows wait for the learner's interval
    finally:
        daemon.send_signal(signal.SIGINT)
        daemon.wait(timeout=60)
        stop.set()
        copier.join()
    print(observed.stdout.strip() or observed.stderr.strip(), f"({streamed:.1f} s)", file=sys.stderr)

    curve = [(0, score(cliff, one, dev))]
    for state in sorted(glob.glob(os.path.join(snaps, "*.state"))):
        words = open(state).read().split()
        rows = int(words[words.index("rows") + 1])
        curve.append((rows, score(cliff, state[: -len(".state")] + ".cliff", dev)))
    learned = sorted(glob.glob(os.path.join(snaps, "*.cliff")))[-1]
    with open(os.path.join(a.out, "score-curve.csv"), "w") as f:
        f.write("rows_learned,mean_log_likelihood\n")
        f.writelines(f"{r},{s:.6f}\n" for r, s in curve)
    ll = {"one": curve[0][1], "learned": curve[-1][1], "all": score(cliff, every, dev)}
    svg(curve, [("all training hours, offline", ll["all"], "#2a8a2a"),
                (f"hour {a.hour} alone", ll["one"], "#b03030")],
        os.path.join(a.out, "score-curve.svg"))

    methods = a.methods.split(",")
    maps = {"one": one, "learned": learned, "all": every}
    per = {k: ade(cliff, p, dev, a.seeds, methods, os.path.join(a.out, "eval-" + k)) for k, p in maps.items()}
    labels = {"one": f"hour {a.hour} alone (the daemon's start)", "learned": "learned by cliffd (last snapshot)",
              "all": "all training hours, offline"}
    print("| map | mean log-likelihood (atc/dev) | vs offline |")
    print("|---|---|---|")
    for k in ("one", "learned", "all"):
        print(f"| {labels[k]} | {ll[k]:.4f} | {ll[k] - ll['all']:+.4f} |")
    print()
    print("| method | map | " + " | ".join(f"ADE {h:g} s (m) | vs offline | reach {h:g} s" for h in HORIZONS) + " |")
    print("|---|---|" + "---|---|---|" * len(HORIZONS))
    def means(k, m, h, i):
        """The mean of value i of map k's and of the offline map's rows, over the people
        both predict (method m, horizon h)."""
        both = [p for p in per[k] if p[0] == m and p[2] == h and p in per["all"]]
        return (sum(per[k][p][i] for p in both) / len(both), sum(per["all"][p][i] for p in both) / len(both))

    for m in methods:
        for k in ("one", "learned", "all"):
            cells = []
            for h in HORIZONS:
                mine, ref = means(k, m, h, 0)
                reach, _ = means(k, m, h, 1)
                cells += [f"{mine:.3f}", f"{100 * (mine / ref - 1):+.1f} %", f"{100 * reach:.0f} %"]
            print(f"| `{m}` | {labels[k]} | " + " | ".join(cells) + " |")
    print()
    print("Top-k errors of the same people (the best of the 20 samples: where the map's other modes show):")
    print()
    print("| method | map | " + " | ".join(f"minADE {h:g} s | minFDE {h:g} s" for h in HORIZONS) + " |")
    print("|---|---|" + "---|---|" * len(HORIZONS))
    for m in methods:
        for k in ("one", "learned", "all"):
            cells = []
            for h in HORIZONS:
                for i in (2, 3):
                    mine, ref = means(k, m, h, i)
                    cells.append(f"{mine:.3f} ({100 * (mine / ref - 1):+.1f} %)")
            print(f"| `{m}` | {labels[k]} | " + " | ".join(cells) + " |")
    if a.all_people:
        sums = {k: summary(cliff, p, dev, a.seeds, methods, os.path.join(a.out, "eval-all-people-" + k))
                for k, p in maps.items()}
        print()
        print("Every person the seconds protocol predicts to each horizon (not only those with 50 s of ground truth):")
        print()
        print("| method | map | " + " | ".join(f"people {h:g} s | ADE | minADE | minFDE" for h in HORIZONS) + " |")
        print("|---|---|" + "---|---|---|---|" * len(HORIZONS))
        for m in methods:
            for k in ("one", "learned", "all"):
                cells = []
                for h in HORIZONS:
                    n, e, mn, mf = sums[k][(m, h)]
                    cells += [f"{n:.0f}", f"{e:.3f}", f"{mn:.3f}", f"{mf:.3f}"]
                print(f"| `{m}` | {labels[k]} | " + " | ".join(cells) + " |")
    print(f"\n{len(curve) - 1} snapshots; curve: {a.out}/score-curve.svg (.csv)")


if __name__ == "__main__":
    main()
