"""THÖR1 people as the reference protocol sees them (a test helper).

The start state is restated here from the published rule (documented in
../shared/docs/cliff-lhmp-reference.md): Gaussian weights exp(-t^2 / (2 sigma^2)),
t = 1..8 with the largest on the most recent observed row, normalised; weighted speed
and weighted circular-mean heading of the 8 observed rows; position and time of the
row after them.
"""

import math
from pathlib import Path
from typing import Dict, Tuple

import numpy as np

OBS_ROWS = 8
SIGMA = 1.5


def read_people(path: Path) -> Dict[int, np.ndarray]:
    """Rows (t, x, y, speed, angle) of every person, in file order."""
    raw = np.loadtxt(path, delimiter=",", ndmin=2)
    people: Dict[int, np.ndarray] = {}
    for pid in dict.fromkeys(raw[:, 1].astype(np.int64).tolist()):
        rows = raw[raw[:, 1] == pid]
        people[int(pid)] = rows[:, [0, 2, 3, 4, 5]]
    return people


def start_row(rows: np.ndarray) -> Tuple[np.ndarray, float, float]:
    """The reference start: (t, x, y) of row 8, speed and heading from rows 0..7."""
    n = OBS_ROWS
    w = np.array([math.exp(-((n - i) ** 2) / (2 * SIGMA * SIGMA)) for i in range(n)])
    w /= w.sum()
    speed = float(np.sum(rows[:n, 3] * w))
    s = float(np.sum(w * np.sin(rows[:n, 4])))
    c = float(np.sum(w * np.cos(rows[:n, 4])))
    heading = math.atan2(s, c) % (2 * math.pi)
    return rows[n, :3], speed, heading


def person_seed(seed: int, person: int) -> int:
    """`cliff eval`'s per-person seed (splitmix64 of the run seed and the person id)."""
    m = (1 << 64) - 1
    z = ((seed * 0x9E3779B97F4A7C15) & m) ^ ((person + 0xD1B54A32D192ED03) & m)
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & m
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & m
    return z ^ (z >> 31)
