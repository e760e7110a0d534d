"""Golden CDR bytes and type hashes of every message cliff-ros2 reads or writes, from
implementations independent of ours.

Bytes: each message of samples.json serialized by the `rosbags` package (pure Python,
its own CDR serializer; rclpy's serialize_message leaves padding bytes uninitialised)
into <package>__msg__<Type>.cdr: the 4-byte encapsulation header, then the CDR body.
The types come from rosbags' Jazzy store and, for the packages it does not ship, from
the .msg files of ros2/cliff_msgs and ros2/tests/{people_msgs,autoware_perception_msgs}.
ros2/tests/golden.rs checks that our serde structs give the same bytes.

Type hashes: RIHS01 of our packages' types as rosbags computes them, which must equal
the official generator's (share/<pkg>/msg/<Type>.json of the colcon build in ros2/.ws)
and type_hashes.json here; and of the wheels' types the node writes (nav_msgs'
OccupancyGrid), which must equal the wheel's share/<pkg>/msg/<Type>.json.

    python make_golden.py           # write the .cdr files and type_hashes.json
    python make_golden.py --check   # compare; prints ok/FAIL lines and `N passed, N failed`
"""
import argparse
import json
import pathlib
import sys

import numpy as np
from rosbags.typesys import Stores, get_typestore, get_types_from_msg
from rosbags.interfaces import Nodetype

HERE = pathlib.Path(__file__).resolve().parent
ROS2 = HERE.parent.parent
PACKAGES = {
    "people_msgs": ROS2 / "tests" / "people_msgs",
    "cliff_msgs": ROS2 / "cliff_msgs",
    "autoware_perception_msgs": ROS2 / "tests" / "autoware_perception_msgs",
}
# written by the node, defined by a Jazzy wheel (no .msg of ours): hashes checked against it
WHEEL_TYPES = ["nav_msgs/msg/OccupancyGrid", "nav_msgs/msg/MapMetaData"]
NUMPY = {"bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8, "uint8": np.uint8,
         "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32,
         "int64": np.int64, "uint64": np.uint64, "float32": np.float32, "float64": np.float64}


def typestore():
    ts = get_typestore(Stores.ROS2_JAZZY)
    types = {}
    for pkg, path in PACKAGES.items():
        for f in sorted((path / "msg").glob("*.msg")):
            types.update(get_types_from_msg(f.read_text(), f"{pkg}/msg/{f.stem}"))
    ts.register(types)
    return ts, sorted(types)


def build(ts, typename, value):
    _, fields = ts.fielddefs[typename]
    return ts.types[typename](**{name: convert(ts, desc, value[name]) for name, desc in fields})


def convert(ts, desc, v):
    kind, detail = desc
    if kind == Nodetype.BASE:
        return v
    if kind == Nodetype.NAME:
        return build(ts, detail, v)
    (sub_kind, sub_detail), _n = detail
    if sub_kind == Nodetype.BASE and sub_detail[0] != "string":
        return np.array(v, dtype=NUMPY[sub_detail[0]])
    return [convert(ts, (sub_kind, sub_detail), x) for x in v]


def official_hash(typename, wheel=False):
    pkg, _, ty = typename.split("/")
    if wheel:
        path = pathlib.Path(sys.prefix) / "share" / pkg / "msg" / f"{ty}.json"
    else:
        path = ROS2 / ".ws" / "install" / pkg / "share" / pkg / "msg" / f"{ty}.json"
    doc = json.loads(path.read_text())
    for h in doc["type_hashes"]:
        if h["type_name"] == typename:
            return h["hash_string"]
    raise KeyError(f"{typename} not in {path}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--check", action="store_true")
    a = ap.parse_args()
    ts, ours = typestore()
    samples = json.loads((HERE / "samples.json").read_text())
    passed = failed = 0

    def check(ok, what):
        nonlocal passed, failed
        print(("ok   " if ok else "FAIL ") + "golden: " + what)
        passed, failed = passed + bool(ok), failed + (not ok)

    for typename, value in samples.items():
        data = bytes(ts.serialize_cdr(build(ts, typename, value), typename))
        path = HERE / (typename.replace("/", "__") + ".cdr")
        if a.check:
            check(path.exists() and path.read_bytes() == data,
                  f"{typename}: rosbags gives the committed {path.name} ({len(data)} bytes)")
        else:
            path.write_bytes(data)
    hashes = {t: ts.hash_rihs01(t) for t in ours}
    # types of the Jazzy wheels the node writes: rosbags' hash against the wheel's own
    wheels = {t: ts.hash_rihs01(t) for t in WHEEL_TYPES}
    hash_file = HERE / "type_hashes.json"
    if a.check:
        committed = json.loads(hash_file.read_text())
        for t, h in hashes.items():
            try:
                official = official_hash(t)
            except (OSError, KeyError) as e:
                check(False, f"{t}: official type hash ({e})")
                continue
            check(h == official == committed.get(t),
                  f"{t}: RIHS01 of rosbags, of the official generator and type_hashes.json agree ({official[:20]}...)")
        for t, h in wheels.items():
            try:
                official = official_hash(t, wheel=True)
            except (OSError, KeyError) as e:
                check(False, f"{t}: the wheel's type hash ({e})")
                continue
            check(h == official, f"{t}: RIHS01 of rosbags equals the Jazzy wheel's ({official[:20]}...)")
        print(f"golden: {passed} passed, {failed} failed")
        return 1 if failed else 0
    hash_file.write_text(json.dumps(hashes, indent=1) + "\n")
    print(f"wrote {len(samples)} .cdr files and {len(hashes)} type hashes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
