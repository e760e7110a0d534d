#!/usr/bin/env python3
"""The README's THÖR1 evaluation from Python, with a figure of the error curves.

    python python/examples/thor1_evaluation.py [--out thor1-curves.png]

Runs the parity setting of `cliff eval` (reference protocol, 3.2 s observed, 12 s at
0.4 s, radius 0.7071, beta 1, k 20, 20 seeds, CLiFF-LHMP and constant velocity) on
../shared/data/thor1 and prints the same table as the command line. With matplotlib
installed (it is optional, only for this example) it draws ADE and FDE against the
horizon, with a band of one standard deviation over seeds.
"""

import argparse
from pathlib import Path

import cliff_lhmp

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "thor1"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="thor1-curves.png", help="figure file (PNG, SVG, PDF)")
    ap.add_argument("--seeds", type=int, default=20)
    a = ap.parse_args()

    m = cliff_lhmp.Map.load(DATA / "cliffmap.csv")
    r = cliff_lhmp.evaluate(
        m, DATA / "exp-1-run-2.csv", format="thor", protocol="reference", obs=3.2, dt=0.4,
        horizon=12.0, radius=0.7071, beta=1.0, k=20, seeds=a.seeds, methods=["cliff", "cvm"],
    )
    print(f"{r.people_evaluated} of {r.people_total} people evaluated")
    print(r.table(), end="")

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no figure (pip install matplotlib)")
        return
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharex=True)
    for method, colour in (("cliff", "tab:blue"), ("cvm", "tab:orange")):
        rows = [s for s in r.summary if s["method"] == method]
        h = [s["horizon"] for s in rows]
        for ax, key in zip(axes, ("ade", "fde")):
            y = [s[key] for s in rows]
            sd = [s[key + "_sd"] for s in rows]
            ax.plot(h, y, color=colour, label=method)
            ax.fill_between(h, [v - e for v, e in zip(y, sd)], [v + e for v, e in zip(y, sd)],
                            color=colour, alpha=0.25)
    for ax, name in zip(axes, ("ADE", "FDE")):
        ax.set_xlabel("prediction horizon (s)")
        ax.set_ylabel(f"{name} (m)")
        ax.grid(alpha=0.3)
        ax.legend()
    fig.suptitle(f"THÖR1: {r.people_evaluated} people, {a.seeds} seeds (band: 1 sd over seeds)")
    fig.tight_layout()
    fig.savefig(a.out, dpi=110)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
