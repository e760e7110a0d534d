#!/usr/bin/env python3
"""Speed of cliff_lhmp.predict against the Rust predictor and a NumPy re-statement of the
published CLiFF-LHMP loop, on the THÖR1 benchmark person (the first THÖR1 person that
passes the reference filter; k 20, 30 steps of 0.4 s, radius 0.7071, beta 1), in one run.

    .venv/bin/python benches/python_predict.py            # from the repository root
    .venv/bin/python benches/python_predict.py --no-rust  # skip `cargo bench`

Figures are medians over repeated batches of calls:

* rust: `cargo bench --bench predict -- '^thor1_person_k20_30steps$'` (criterion's
  estimate of the same call made from Rust), run by this script;
* python, 1 person: `cliff_lhmp.predict(map, [history], k=20, ...)` per call, the seed
  changing from call to call as in the Rust benchmark;
* python, 1,000 people: one call with the same person 1,000 times;
* numpy baseline: `reference_like_predict` below, a straightforward NumPy re-statement
  of the published implementation's per-sample loop as ../shared/docs/
  cliff-lhmp-reference.md describes it, with NumPy's legacy generator (`choice`,
  `multivariate_normal`) as the published code seeds it (see BENCHMARKS.md: it is not
  the published code, which is not available here).
"""

import argparse
import math
import os
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import cliff_lhmp

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
sys.path.insert(0, str(ROOT / "python" / "tests"))
from thor import read_people, start_row  # noqa: E402

OBS = 8


def passes_reference_filter(rows: np.ndarray, dt: float = 0.4) -> bool:
    """The published code's filter (cliff-lhmp-reference.md, step 1)."""
    if len(rows) < OBS + 2 or rows[-1, 0] - rows[OBS, 0] < dt:
        return False
    w = 10
    for i in range(len(rows) - w):
        if math.hypot(*(rows[i + w, 1:3] - rows[i, 1:3])) < 1.0:
            return False
    return True


def benchmark_person():
    people = read_people(DATA / "thor1" / "exp-1-run-2.csv")
    for pid, rows in people.items():
        if passes_reference_filter(rows):
            return pid, rows
    raise SystemExit("no THÖR1 person passes the filter")


def per_call(fn, calls: int, repeats: int) -> float:
    """Median over `repeats` batches of the time per call (s)."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        times.append((time.perf_counter() - t0) / calls)
    return statistics.median(times)


def reference_like_predict(locs, comps_of, ratio, start, k, steps, dt, r_s, beta, rng):
    """The published CLiFF-LHMP sampling loop, restated with NumPy (one sample at a time).

    Per step: all locations whose squared distance is below r_s (the reference's
    quirk), the one with the largest observation ratio, a component chosen by weight,
    (theta, rho) drawn from its bivariate normal, theta' the circular weighted mean of
    the sampled and current heading (weights lambda = exp(-beta delta^2), 1 - lambda),
    then a constant-speed move; a sample stops when no location is near.
    """
    x0, y0, rho0, th0 = start
    out = []
    for _ in range(k):
        x, y, th = x0, y0, th0
        traj = []
        for _ in range(steps):
            d2 = (locs[:, 0] - x) ** 2 + (locs[:, 1] - y) ** 2
            near = np.nonzero(d2 < r_s)[0]
            if near.size == 0:
                break
            best = near[np.argmax(ratio[near])]
            means, covs, weights = comps_of[best]
            c = rng.choice(len(weights), p=weights)
            theta_s, _rho_s = rng.multivariate_normal(means[c], covs[c])
            theta_s %= 2 * math.pi
            delta = abs((theta_s - th + math.pi) % (2 * math.pi) - math.pi)
            lam = math.exp(-beta * delta * delta)
            th = math.atan2(lam * math.sin(theta_s) + (1 - lam) * math.sin(th),
                            lam * math.cos(theta_s) + (1 - lam) * math.cos(th))
            x += rho0 * math.cos(th) * dt
            y += rho0 * math.sin(th) * dt
            traj.append((x, y))
        out.append(traj)
    return out


def rust_time() -> float:
    cmd = ["cargo", "bench", "--bench", "predict", "--", "^thor1_person_k20_30steps$"]
    print("running:", " ".join(cmd), file=sys.stderr)
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=True).stdout
    m = re.search(r"thor1_person_k20_30steps\s+time:\s+\[(\S+) (\S+) (\S+) (\S+) (\S+) (\S+)\]", out)
    if not m:
        raise SystemExit("cannot read criterion's output:\n" + out)
    value, unit = float(m.group(3)), m.group(4)
    return value * {"ns": 1e-9, "µs": 1e-6, "us": 1e-6, "ms": 1e-3, "s": 1.0}[unit]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--no-rust", action="store_true", help="skip cargo bench")
    ap.add_argument("--repeats", type=int, default=15)
    a = ap.parse_args()

    m = cliff_lhmp.Map.load(DATA / "thor1" / "cliffmap.csv")
    pid, rows = benchmark_person()
    (t, x, y), speed, heading = start_row(rows)
    history = np.array([[t, x, y, speed, heading]])
    kw = dict(k=20, dt=0.4, horizon=12.0, radius=0.7071, beta=1.0)
    seed = [0]

    def one():
        seed[0] += 1
        cliff_lhmp.predict(m, [history], seed=seed[0], **kw)

    batch = [history] * 1000

    def thousand():
        seed[0] += 1
        cliff_lhmp.predict(m, batch, seed=seed[0], **kw)

    for _ in range(2000):
        one()
    py1 = per_call(one, 5000, a.repeats)
    py1000 = per_call(thousand, 5, a.repeats)

    # the NumPy re-statement of the published loop, on the same person
    comps = m.components
    owner = m.component_location
    comps_of = []
    for i in range(len(m.locations)):
        c = comps[owner == i]
        covs = c[:, 4:8].reshape(-1, 2, 2)
        comps_of.append((c[:, 2:4], covs, c[:, 8] / c[:, 8].sum()))
    rng = np.random.RandomState(0)  # the published code seeds NumPy's legacy generator
    locs, ratio = m.locations, m.observation_ratio
    import warnings

    warnings.simplefilter("ignore", RuntimeWarning)  # slightly non-PSD covariances

    def reference():
        reference_like_predict(locs, comps_of, ratio, (x, y, speed, heading), 20, 30, 0.4,
                               0.5, 1.0, rng)

    ref = per_call(reference, 3, max(5, a.repeats // 3))
    rust = None if a.no_rust else rust_time()

    load = os.getloadavg()
    print(f"THÖR1 person {pid}, k 20, 30 steps, radius 0.7071; load average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f}")
    if rust is not None:
        print(f"rust in-process (criterion)         {rust * 1e6:10.2f} us")
    print(f"python, 1 person per call           {py1 * 1e6:10.2f} us" +
          (f"   ({py1 / rust:.2f}x rust)" if rust else ""))
    print(f"python, 1,000 people in one call    {py1000 * 1e3:10.3f} ms" +
          (f"   ({py1000 / (1000 * rust):.2f}x 1,000 x rust)" if rust else ""))
    print(f"  per person                        {py1000 * 1e3:10.2f} us")
    print(f"numpy re-statement of the reference {ref * 1e3:10.2f} ms   "
          f"({ref / py1:,.0f}x python 1 person)")


if __name__ == "__main__":
    main()
