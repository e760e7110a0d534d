"""rosbag2 recordings for the tests, written by the `rosbags` package (an independent
rosbag2 writer and CDR serializer): THÖR rows as people_msgs/msg/People messages, and
pedestrians among other objects as autoware_perception_msgs/msg/TrackedObjects.

The message types are registered from their .msg files in ros2/tests (people_msgs as
the node's tests use it; autoware_perception_msgs as vendored from autoware_msgs).
"""

import csv
import math
from decimal import Decimal
from pathlib import Path
from typing import Any, Dict, Iterable, List, Sequence, Tuple

from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

ROOT = Path(__file__).resolve().parents[2]
MSGS = ROOT / "ros2" / "tests"
PEOPLE = "people_msgs/msg/People"
TRACKED = "autoware_perception_msgs/msg/TrackedObjects"

# THÖR rows: (time text, person id text, x, y, speed, motion angle)
Row = Tuple[str, str, float, float, float, float]


def typestore() -> Any:
    """ROS 2 Jazzy's standard types plus people_msgs and autoware_perception_msgs."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types: Dict[str, Any] = {}
    for package in ("people_msgs", "autoware_perception_msgs"):
        for msg in sorted((MSGS / package / "msg").glob("*.msg")):
            types.update(get_types_from_msg(msg.read_text(), f"{package}/msg/{msg.stem}"))
    if "unique_identifier_msgs/msg/UUID" not in store.fielddefs:
        types.update(get_types_from_msg("uint8[16] uuid", "unique_identifier_msgs/msg/UUID"))
    store.register(types)
    return store


def read_thor(path: Path) -> List[Row]:
    """The rows of a THÖR/ATC file, time and id as their text."""
    with open(path, newline="") as f:
        return [(r[0], r[1], float(r[2]), float(r[3]), float(r[4]), float(r[5]))
                for r in csv.reader(f) if r]


def stamp(time: str) -> Tuple[int, int]:
    """`(sec, nanosec)` of a decimal time, exactly."""
    ns = int(Decimal(time) * 10**9)
    return ns // 10**9, ns % 10**9


def velocity(speed: float, angle: float) -> Tuple[float, float]:
    """The velocity of a speed and motion angle: of the floats within a few units in the
    last place of `speed * (cos, sin)(angle)`, the first whose length and direction
    (`sqrt(vx^2 + vy^2)`, `atan2(vy, vx)`, as cliff computes them) are `speed` and
    `angle` exactly; where no such pair exists (about 5 % of THÖR1's rows), the plain
    product."""
    if speed == 0.0 and angle == 0.0:
        return 0.0, 0.0
    vx, vy = speed * math.cos(angle), speed * math.sin(angle)

    def step(v: float, n: int) -> float:
        for _ in range(abs(n)):
            v = math.nextafter(v, math.copysign(math.inf, n))
        return v

    for r in range(6):
        for i in range(-r, r + 1):
            for j in range(-r, r + 1):
                if max(abs(i), abs(j)) != r:
                    continue
                x, y = step(vx, i), step(vy, j)
                if math.sqrt(x * x + y * y) == speed and math.atan2(y, x) == angle:
                    return x, y
    return vx, vy


def by_time(rows: Iterable[Row]) -> List[Tuple[str, List[Row]]]:
    """Rows grouped by time stamp, in time order (each group in file order)."""
    groups: Dict[str, List[Row]] = {}
    for r in rows:
        groups.setdefault(r[0], []).append(r)
    return sorted(groups.items(), key=lambda g: Decimal(g[0]))


def writer(path: Path) -> Writer:
    """A rosbag2 MCAP writer with zstd-compressed chunks."""
    w = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    w.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    return w


def people_message(store: Any, time: str, rows: Sequence[Row], frame: str = "map") -> Any:
    """A People message of the rows seen at `time`."""
    Header = store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    Point = store.types["geometry_msgs/msg/Point"]
    Person = store.types["people_msgs/msg/Person"]
    People = store.types[PEOPLE]
    sec, nanosec = stamp(time)
    people = []
    for _, pid, x, y, speed, angle in rows:
        vx, vy = velocity(speed, angle)
        people.append(Person(name=pid, position=Point(x=x, y=y, z=0.0),
                             velocity=Point(x=vx, y=vy, z=0.0), reliability=1.0,
                             tagnames=["source"], tags=["thor"]))
    return People(header=Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id=frame),
                  people=people)


def write_people_bag(folder: Path, rows: Sequence[Row], topic: str = "/people",
                     raw: Dict[int, bytes] = {}) -> Path:
    """A rosbag2 folder holding one People message per time stamp of `rows` on `topic`
    (log times from the stamps); `raw` replaces the serialized bytes of the messages it
    numbers (1-based). Returns the .mcap file."""
    store = typestore()
    with writer(folder) as w:
        conn = w.add_connection(topic, PEOPLE, typestore=store)
        for i, (time, group) in enumerate(by_time(rows), start=1):
            data = raw.get(i)
            if data is None:
                data = store.serialize_cdr(people_message(store, time, group), PEOPLE)
            sec, nanosec = stamp(time)
            w.write(conn, sec * 10**9 + nanosec, data)
    return mcap_of(folder)


def write_velocity_csv(path: Path, rows: Sequence[Row]) -> None:
    """The rows as a named-column CSV (t, id, x, y, vx, vy), in the order a People bag
    holds them (by time), the velocities exactly as the bag's."""
    with open(path, "w") as f:
        f.write("t,id,x,y,vx,vy\n")
        for time, group in by_time(rows):
            for _, pid, x, y, speed, angle in group:
                vx, vy = velocity(speed, angle)
                f.write(f"{time},{pid},{x!r},{y!r},{vx!r},{vy!r}\n")


def mcap_of(folder: Path) -> Path:
    """The one .mcap file of a rosbag2 folder."""
    (path,) = folder.glob("*.mcap")
    return path


def tracked_objects_message(store: Any, time: str,
                            objects: Sequence[Tuple[bytes, List[Tuple[int, float]], float, float]],
                            ) -> Any:
    """A TrackedObjects message: per object its uuid, classification (label,
    probability) and position."""
    import numpy as np

    t = store.types
    sec, nanosec = stamp(time)
    out = []
    for uuid, classes, x, y in objects:
        zero3 = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        cov = np.zeros(36, dtype=np.float64)
        pose = t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=x, y=y, z=0.5),
            orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))
        kin = t["autoware_perception_msgs/msg/TrackedObjectKinematics"](
            pose_with_covariance=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=cov),
            twist_with_covariance=t["geometry_msgs/msg/TwistWithCovariance"](
                twist=t["geometry_msgs/msg/Twist"](linear=zero3, angular=zero3), covariance=cov),
            acceleration_with_covariance=t["geometry_msgs/msg/AccelWithCovariance"](
                accel=t["geometry_msgs/msg/Accel"](linear=zero3, angular=zero3), covariance=cov),
            orientation_availability=0, is_stationary=False)
        shape = t["autoware_perception_msgs/msg/Shape"](
            type=1,
            footprint=t["geometry_msgs/msg/Polygon"](
                points=[t["geometry_msgs/msg/Point32"](x=0.1, y=0.2, z=0.0)]),
            dimensions=t["geometry_msgs/msg/Vector3"](x=0.5, y=0.5, z=1.7))
        out.append(t["autoware_perception_msgs/msg/TrackedObject"](
            object_id=t["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(uuid, dtype=np.uint8)),
            existence_probability=0.9,
            classification=[t["autoware_perception_msgs/msg/ObjectClassification"](
                label=label, probability=p) for label, p in classes],
            kinematics=kin, shape=shape))
    header = t["std_msgs/msg/Header"](
        stamp=t["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id="map")
    return t[TRACKED](header=header, objects=out)
