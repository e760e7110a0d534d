"""cliff_lhmp: CLiFF-maps and CLiFF-LHMP long-term human motion prediction.

A native (Rust) package with NumPy arrays in and out:

* ``Map``: load (``Map.load``, CSV or ``.cliff`` snapshot), ``Map.demo()``, ``save``,
  ``info()``, locations and components as arrays, ``score``; ``build_map`` and
  ``OnlineMap`` to learn maps from trajectories.
* ``predict(map, histories, ...)``: k sampled futures per person, in-process, as a
  ``Prediction`` (``positions`` (people, k, steps, 2), ``lengths`` (people, k)).
* ``Client``: the same predictions from a running ``cliffd`` daemon, on this host
  (``Client()``, shared memory) or another (``Client.connect_zenoh(endpoint)``, in a
  package built with the cargo feature ``zenoh``: see ``HAS_ZENOH``); exceptions
  ``Rejected``, ``NoDaemon``, ``DaemonGone``, ``DeadlinePassed``.
* ``evaluate``: ``cliff eval`` from Python, tables as lists of dicts.

Example:
    >>> import numpy as np, cliff_lhmp
    >>> m = cliff_lhmp.Map.demo()
    >>> walk = np.array([[0.0, -10.0, 0.5], [0.4, -9.5, 0.5], [0.8, -9.0, 0.5]])
    >>> p = cliff_lhmp.predict(m, [walk], k=20, horizon=12.0)
    >>> p.positions.shape
    (1, 20, 30, 2)
"""

from importlib.metadata import PackageNotFoundError, version

from ._errors import DaemonGone, DeadlinePassed, NoDaemon, Rejected
from ._native import (
    HAS_ZENOH,
    Client,
    Evaluation,
    Map,
    OnlineMap,
    Prediction,
    build_map,
    evaluate,
    predict,
)

try:
    __version__ = version("cliff-lhmp")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0+unknown"

__all__ = [
    "Client",
    "DaemonGone",
    "DeadlinePassed",
    "Evaluation",
    "HAS_ZENOH",
    "Map",
    "NoDaemon",
    "OnlineMap",
    "Prediction",
    "Rejected",
    "build_map",
    "evaluate",
    "predict",
]
