"""A typed use of the package: `mypy --strict` must accept it (see test_api.py)."""

from pathlib import Path
from typing import Dict, List

import numpy as np
import numpy.typing as npt

import cliff_lhmp


def main() -> None:
    m: cliff_lhmp.Map = cliff_lhmp.Map.demo()
    walk: npt.NDArray[np.float64] = np.array([[0.0, -10.0, 0.5], [0.4, -9.5, 0.5]])
    p: cliff_lhmp.Prediction = cliff_lhmp.predict(m, [walk], k=5, seed=1, method="cvm")
    positions: npt.NDArray[np.float32] = p.positions
    lengths: npt.NDArray[np.int64] = p.lengths
    first: npt.NDArray[np.float32] = p.sample(0, 0)
    scored = cliff_lhmp.predict(
        m, [walk], k=5, method="improved", speed_beta=2.0, coast=4.0, scores=True, time="all-day"
    )
    scores: "npt.NDArray[np.float32] | None" = scored.scores
    best: "int | None" = scored.best_sample(0)
    at_noon = cliff_lhmp.predict(m, [walk], time=1_351_771_200.0)
    locs: npt.NDArray[np.float64] = m.locations
    info: Dict[str, object] = m.info()
    score: Dict[str, float] = m.score("tracks.csv", format="thor", radius=None)
    built: cliff_lhmp.Map = cliff_lhmp.build_map(["a.csv", "b.csv"], format="atc", grid=1.0)
    online = cliff_lhmp.OnlineMap(built, decay=0.5)
    report: Dict[str, int] = online.update("c.csv", format="atc")
    r: cliff_lhmp.Evaluation = cliff_lhmp.evaluate(m, "tracks.csv", seeds=2, methods=["cvm"])
    rows: List[Dict[str, object]] = r.summary
    table: str = r.table([2.0, 4.0])
    try:
        c = cliff_lhmp.Client("cliff/predict", prefix=None, wait="spin", deadline=0.05)
        q: cliff_lhmp.Prediction = c.predict("demo", [walk], k=3, scores=True, time=None)
        c.reload_maps()
    except cliff_lhmp.Rejected as e:
        status: str = e.status
        field: "str | None" = e.field
        print(status, field)
    except (cliff_lhmp.NoDaemon, cliff_lhmp.DaemonGone, cliff_lhmp.DeadlinePassed) as e:
        print(e)
    if cliff_lhmp.HAS_ZENOH:
        z = cliff_lhmp.Client.connect_zenoh("tcp/127.0.0.1:7447", "cliff/predict", deadline=0.1)
        z2 = cliff_lhmp.Client.connect_zenoh(["tcp/10.0.0.2:7447"], config="robot.json5")
        z3 = cliff_lhmp.Client.connect_zenoh(None, config=Path("robot.json5"))
        zq: cliff_lhmp.Prediction = z.predict("demo", [walk], k=3, seed=2)
        transport: str = z2.transport
        print(zq, transport, z3.service)
    print(scores, best, at_noon)
    print(positions, lengths, first, locs, info, score, report, rows, table, q if False else None)
