"""Type stubs of cliff_lhmp (the public API)."""

import os
from typing import Any, Dict, List, Literal, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt

from ._errors import DaemonGone as DaemonGone
from ._errors import DeadlinePassed as DeadlinePassed
from ._errors import NoDaemon as NoDaemon
from ._errors import Rejected as Rejected

__version__: str
HAS_ZENOH: bool

_Path = Union[str, "os.PathLike[str]"]
_Tracks = Union[_Path, Sequence[_Path]]
_History = Union[npt.ArrayLike, npt.NDArray[np.float64]]
_Histories = Union[Sequence[_History], npt.NDArray[np.float64]]
# None or "now": the wall clock; seconds on the map's clock; "all-day": the all-day map
_Time = Union[None, float, Literal["now", "all-day"]]

@final
class Map:
    """A CLiFF-map: for each location, a mixture of the velocities people moved with."""

    @staticmethod
    def load(path: _Path) -> Map: ...
    @staticmethod
    def demo() -> Map: ...
    def slice_at(self, time: float, *, clock_offset: Optional[float] = None) -> Map: ...
    def save(self, path: _Path) -> None: ...
    def info(self) -> Dict[str, Any]: ...
    @property
    def locations(self) -> npt.NDArray[np.float64]: ...
    @property
    def observation_ratio(self) -> npt.NDArray[np.float64]: ...
    @property
    def motion_ratio(self) -> npt.NDArray[np.float64]: ...
    @property
    def components(self) -> npt.NDArray[np.float64]: ...
    @property
    def component_location(self) -> npt.NDArray[np.int64]: ...
    def score(
        self,
        tracks: _Tracks,
        *,
        format: Optional[str] = None,
        radius: Optional[float] = None,
        topic: Optional[str] = None,
    ) -> Dict[str, float]: ...
    def predict(
        self,
        histories: _Histories,
        *,
        k: int = 20,
        dt: float = 0.4,
        horizon: float = 12.0,
        beta: float = 1.0,
        radius: float = 0.7071067811865476,
        seed: int = 0,
        method: str = "cliff",
        heading: str = "circular-mean",
        speed_beta: float = 0.0,
        coast: float = 0.0,
        scores: bool = False,
        time: _Time = None,
    ) -> Prediction: ...

@final
class OnlineMap:
    """A map that learns online from batches of trajectories."""

    def __init__(
        self,
        map: Map,
        *,
        count_scale: Optional[float] = None,
        decay: float = 0.5,
        radius: Optional[float] = None,
    ) -> None: ...
    def update(
        self, tracks: _Tracks, *, format: Optional[str] = None, topic: Optional[str] = None
    ) -> Dict[str, int]: ...
    @property
    def count_scale(self) -> float: ...
    def map(self) -> Map: ...
    def __len__(self) -> int: ...

@final
class Prediction:
    """Sampled future trajectories of a batch of people."""

    @property
    def positions(self) -> npt.NDArray[np.float32]: ...
    @property
    def lengths(self) -> npt.NDArray[np.int64]: ...
    @property
    def dt(self) -> float: ...
    @property
    def agents(self) -> int: ...
    @property
    def k(self) -> int: ...
    @property
    def steps(self) -> int: ...
    @property
    def scores(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def map_version(self) -> int: ...
    def sample(self, agent: int, s: int) -> npt.NDArray[np.float32]: ...
    def best_sample(self, agent: int) -> Optional[int]: ...
    def occupancy(
        self,
        grid: Union[Dict[str, Any], Tuple[float, float, float, int, int]],
        times: Sequence[float],
        person_radius: float = 0.3,
        bandwidth_scale: float = 1.0,
        stopped: str = "renormalise",
    ) -> npt.NDArray[np.float32]: ...
    def occupancy_window(
        self,
        grid: Union[Dict[str, Any], Tuple[float, float, float, int, int]],
        start: float,
        end: float,
        person_radius: float = 0.3,
        bandwidth_scale: float = 1.0,
        stopped: str = "renormalise",
    ) -> npt.NDArray[np.float32]: ...
    def path_meets(
        self,
        plan: Sequence[Tuple[float, float, float]],
        robot_radius: float,
        person_radius: float = 0.3,
        stopped: str = "renormalise",
    ) -> npt.NDArray[np.float32]: ...
    def __len__(self) -> int: ...

@final
class Evaluation:
    """The result of evaluate(): summary and per-person tables."""

    @property
    def summary(self) -> List[Dict[str, Any]]: ...
    @property
    def per_person(self) -> List[Dict[str, Any]]: ...
    @property
    def people_total(self) -> int: ...
    @property
    def people_evaluated(self) -> int: ...
    def table(self, horizons: Optional[Sequence[float]] = None) -> str: ...

@final
class Client:
    """A connection to the cliffd daemon (shared memory on this host, or zenoh)."""

    def __init__(
        self,
        service: str = "cliff/predict",
        prefix: Optional[str] = None,
        wait: str = "hybrid",
        deadline: float = 0.05,
    ) -> None: ...
    @staticmethod
    def connect_zenoh(
        endpoint: Union[str, Sequence[str], None],
        service: str = "cliff/predict",
        *,
        config: Optional[_Path] = None,
        deadline: float = 0.05,
    ) -> Client: ...
    def predict(
        self,
        map: str,
        histories: _Histories,
        *,
        k: int = 20,
        dt: float = 0.4,
        horizon: float = 12.0,
        beta: float = 1.0,
        radius: float = 0.7071067811865476,
        seed: int = 0,
        method: str = "cliff",
        heading: str = "circular-mean",
        speed_beta: float = 0.0,
        coast: float = 0.0,
        scores: bool = False,
        time: _Time = None,
    ) -> Prediction: ...
    def reload_maps(self) -> None: ...
    def observe(self, map: str, track: int, rows: _History, *, end: bool = False) -> Dict[str, int]: ...
    @property
    def service(self) -> str: ...
    @property
    def transport(self) -> str: ...

def predict(
    map: Map,
    histories: _Histories,
    *,
    k: int = 20,
    dt: float = 0.4,
    horizon: float = 12.0,
    beta: float = 1.0,
    radius: float = 0.7071067811865476,
    seed: int = 0,
    method: str = "cliff",
    heading: str = "circular-mean",
    speed_beta: float = 0.0,
    coast: float = 0.0,
    scores: bool = False,
    time: _Time = None,
) -> Prediction: ...
def build_map(
    tracks: _Tracks,
    *,
    format: Optional[str] = None,
    grid: float = 1.0,
    radius: float = 1.0,
    topic: Optional[str] = None,
) -> Map: ...
def evaluate(
    map: Map,
    tracks: _Tracks,
    *,
    format: Optional[str] = None,
    protocol: str = "seconds",
    obs: float = 3.2,
    dt: float = 0.4,
    horizon: float = 12.0,
    radius: float = 0.7071067811865476,
    beta: float = 1.0,
    k: int = 20,
    seeds: int = 1,
    methods: Optional[Sequence[str]] = None,
    sigma: float = 1.5,
    heading: str = "circular-mean",
    topic: Optional[str] = None,
    count: str = "reached",
    max_speed: Optional[float] = None,
) -> Evaluation: ...
