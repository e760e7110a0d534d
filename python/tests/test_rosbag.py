"""rosbag2 recordings (MCAP) as track input, against the `rosbags` package: bags it
writes (zstd-compressed chunks) give the maps the same rows give as CSV, through the
command line and the Python package, and damaged or foreign bags give errors naming
the file, the topic, the message and the field."""

import math
import struct
import subprocess
from decimal import Decimal
from pathlib import Path
from typing import List

import numpy as np
import pytest

import cliff_lhmp
from bags import (PEOPLE, TRACKED, Row, by_time, mcap_of, people_message, read_thor, stamp,
                  tracked_objects_message, typestore, write_people_bag, write_velocity_csv,
                  writer)
from conftest import THOR1_MAP, THOR1_TRACKS, binary, run_cli

BUILD = ["--grid", "0.5", "--radius", "0.5", "--quiet"]


@pytest.fixture(scope="module")
def thor1_bag(tmp_path_factory) -> Path:
    """THÖR1 round 2 as People messages on /people."""
    return write_people_bag(tmp_path_factory.mktemp("bag") / "thor1", read_thor(THOR1_TRACKS))


@pytest.fixture(scope="module")
def thor1_velocity_csv(tmp_path_factory) -> Path:
    """The same rows as a CSV with the bag's velocities, in the bag's order."""
    path = tmp_path_factory.mktemp("csv") / "thor1-velocity.csv"
    write_velocity_csv(path, read_thor(THOR1_TRACKS))
    return path


def cli_fails(*args: str) -> str:
    """Run `cliff`, expecting it to fail; its standard error."""
    out = subprocess.run([str(binary("cliff")), *args], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode != 0, f"cliff {' '.join(args)} succeeded"
    return out.stderr


def map_rows(path: Path) -> np.ndarray:
    return np.loadtxt(path, delimiter=",", ndmin=2)


def test_bag_is_zstd_chunked_mcap(thor1_bag):
    data = thor1_bag.read_bytes()
    assert data.startswith(b"\x89MCAP0\r\n")
    assert b"zstd" in data and b"people_msgs/msg/People" in data


def test_map_build_from_a_bag_is_the_map_of_its_rows(tmp_path, thor1_bag, thor1_velocity_csv):
    from_bag = tmp_path / "bag.csv"
    run_cli("map", "build", "--tracks", str(thor1_bag), "--topic", "/people", *BUILD,
            "--out", str(from_bag))
    # the same rows read by the named-column CSV reader: byte for byte the same map
    from_csv = tmp_path / "velocity.csv"
    run_cli("map", "build", "--tracks", str(thor1_velocity_csv), "--format", "csv",
            "--columns", "t=t,id=id,x=x,y=y,vx=vx,vy=vy", *BUILD, "--out", str(from_csv))
    assert from_bag.read_bytes() == from_csv.read_bytes()
    # and the map of the THÖR file itself: the same locations and components, the values
    # equal to rounding: a speed and angle turned into a velocity vector and back do not
    # give every float back (bags.velocity); that the bag holds people by time and the
    # file by person does not matter (each location's samples are fitted in one
    # canonical order)
    thor = tmp_path / "thor.csv"
    run_cli("map", "build", "--tracks", str(THOR1_TRACKS), "--format", "thor", *BUILD,
            "--out", str(thor))
    a = map_rows(from_bag)
    b = map_rows(thor)
    assert a.shape == b.shape and a.shape[0] > 400
    a = a[np.lexsort((a[:, 3], a[:, 2], a[:, 1], a[:, 0]))]
    b = b[np.lexsort((b[:, 3], b[:, 2], b[:, 1], b[:, 0]))]
    np.testing.assert_array_equal(a[:, :2], b[:, :2])
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)


def test_format_and_topic_defaults(tmp_path, thor1_bag):
    # without --topic: the one topic of people; --format rosbag2 as well as detection
    outs = []
    for extra in ([], ["--format", "rosbag2"], ["--format", "thor", "--topic", "/people"]):
        out = tmp_path / f"m{len(outs)}.csv"
        run_cli("map", "build", "--tracks", str(thor1_bag), *extra, *BUILD, "--out", str(out))
        outs.append(out.read_bytes())
    assert outs[0] == outs[1] == outs[2]
    assert "--topic <TOPIC>" in run_cli("map", "build", "--help")
    err = cli_fails("map", "build", "--tracks", str(THOR1_TRACKS), "--format", "thor",
                    "--topic", "/people", "--out", str(tmp_path / "x.csv"))
    assert "a topic is for rosbag2 recordings (MCAP files), not thor text files" in err


def test_map_score_and_eval_read_a_bag(thor1_bag, thor1_velocity_csv):
    import json

    bag = json.loads(run_cli("map", "score", "--map", str(THOR1_MAP), "--tracks",
                             str(thor1_bag), "--topic", "/people", "--json"))
    csv = json.loads(run_cli("map", "score", "--map", str(THOR1_MAP), "--tracks",
                             str(thor1_velocity_csv), "--format", "csv", "--columns",
                             "t=t,id=id,x=x,y=y,vx=vx,vy=vy", "--json"))
    assert bag == csv and bag["observations"] > 1000
    ev_bag = run_cli("eval", "--map", str(THOR1_MAP), "--tracks", str(thor1_bag), "--topic",
                     "/people", "--methods", "cvm", "--horizon", "4.8")
    ev_csv = run_cli("eval", "--map", str(THOR1_MAP), "--tracks", str(thor1_velocity_csv),
                     "--format", "csv", "--columns", "t=t,id=id,x=x,y=y,vx=vx,vy=vy",
                     "--methods", "cvm", "--horizon", "4.8")
    assert ev_bag == ev_csv and "cvm" in ev_bag


def test_python_build_map_score_and_evaluate_read_a_bag(tmp_path, thor1_bag):
    import json
    import re

    m = cliff_lhmp.build_map(thor1_bag, topic="/people", grid=0.5, radius=0.5)
    out = tmp_path / "cli.csv"
    run_cli("map", "build", "--tracks", str(thor1_bag), "--topic", "/people", *BUILD,
            "--out", str(out))
    cli = cliff_lhmp.Map.load(out)
    np.testing.assert_array_equal(m.locations, cli.locations)
    np.testing.assert_array_equal(m.components, cli.components)
    # the format argument does not matter for an MCAP file; the topic may be left out
    again = cliff_lhmp.build_map(str(thor1_bag), format="atc", grid=0.5, radius=0.5)
    np.testing.assert_array_equal(again.components, m.components)
    shipped = cliff_lhmp.Map.load(THOR1_MAP)
    got = shipped.score(thor1_bag, topic="/people")
    want = json.loads(run_cli("map", "score", "--map", str(THOR1_MAP), "--tracks",
                              str(thor1_bag), "--json"))
    assert got["observations"] == want["observations"] == 2114
    assert got["mean_log_likelihood"] == pytest.approx(want["mean_log_likelihood"], rel=1e-12)
    ev = cliff_lhmp.evaluate(shipped, thor1_bag, topic="/people", methods=["cvm"], horizon=4.8)
    text = run_cli("eval", "--map", str(THOR1_MAP), "--tracks", str(thor1_bag), "--methods",
                   "cvm", "--horizon", "4.8")
    evaluated, total = map(int, re.match(r"(\d+) of (\d+) people evaluated", text).groups())
    assert (ev.people_evaluated, ev.people_total) == (evaluated, total) == (62, 87)
    cli_ade = {float(line.split()[1].rstrip("s")): float(line.split()[3])
               for line in text.splitlines() if line.startswith("cvm")}
    ade = {round(row["horizon"], 6): row["ade"] for row in ev.summary}
    assert [ade[h] for h in cli_ade] == pytest.approx(list(cli_ade.values()), abs=5e-4)
    online = cliff_lhmp.OnlineMap(shipped)
    assert online.update(thor1_bag)["observations"] == 2180


def rows_of(n_people: int = 2, steps: int = 4) -> List[Row]:
    """A few people walking along x, one row each 0.4 s."""
    rows: List[Row] = []
    for k in range(steps):
        for p in range(n_people):
            rows.append((f"{k * 0.4:.1f}", str(p + 1), 0.5 * k, float(p), 1.0 + 0.1 * k + 0.05 * p,
                         0.1 * p - 0.05 * k))
    return rows


def test_another_type_or_a_missing_topic_is_an_error(tmp_path):
    store = typestore()
    folder = tmp_path / "poses"
    with writer(folder) as w:
        conn = w.add_connection("/people", "geometry_msgs/msg/PoseArray", typestore=store)
        msg = store.types["geometry_msgs/msg/PoseArray"](
            header=store.types["std_msgs/msg/Header"](
                stamp=store.types["builtin_interfaces/msg/Time"](sec=1, nanosec=0),
                frame_id="map"), poses=[])
        w.write(conn, 10**9, store.serialize_cdr(msg, "geometry_msgs/msg/PoseArray"))
        other = w.add_connection("/scan_people", PEOPLE, typestore=store)
        w.write(other, 10**9, store.serialize_cdr(people_message(store, "1.0", rows_of()[:2]),
                                                  PEOPLE))
    bag = mcap_of(folder)
    with pytest.raises(ValueError) as e:
        cliff_lhmp.build_map(bag, topic="/people")
    assert str(e.value) == (f"tracks: {bag}: topic /people carries geometry_msgs/msg/PoseArray, "
                            "not a type cliff reads (people_msgs/msg/People, "
                            "autoware_perception_msgs/msg/TrackedObjects)")
    with pytest.raises(ValueError) as e:
        cliff_lhmp.build_map(bag, topic="/tracks")
    assert str(e.value) == (f"tracks: {bag}: no messages on topic /tracks; its topics: "
                            "/people (geometry_msgs/msg/PoseArray), "
                            "/scan_people (people_msgs/msg/People)")
    err = cli_fails("map", "build", "--tracks", str(bag), "--topic", "/people", "--out",
                    str(tmp_path / "m.csv"))
    assert "topic /people carries geometry_msgs/msg/PoseArray" in err and str(bag) in err
    # without a topic, the one topic of people is read: its two people
    assert cliff_lhmp.Map.load(THOR1_MAP).score(bag)["observations"] == 2


def test_a_truncated_bag_is_an_error(tmp_path, thor1_bag):
    data = thor1_bag.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError) as e:
        cliff_lhmp.build_map(cut)
    text = str(e.value)
    assert text.startswith(f"tracks: {cut}: not a readable rosbag2 MCAP recording: ")
    # the messages before the cut were read; the error says how many
    n = int(text.split("(after ")[1].split(" messages)")[0])
    assert 0 < n < len(by_time(read_thor(THOR1_TRACKS)))
    err = cli_fails("map", "build", "--tracks", str(cut), "--out", str(tmp_path / "m.csv"))
    assert str(cut) in err and "not a readable rosbag2 MCAP recording" in err


def test_a_bad_field_is_named_with_its_message(tmp_path):
    store = typestore()
    rows = rows_of()
    groups = by_time(rows)
    good = bytes(store.serialize_cdr(people_message(store, *groups[2]), PEOPLE))
    # message 3: the first person's name length (after the 4-byte encapsulation, the
    # stamp, the frame "map" and the count of people) set to four billion
    name_at = 4 + 8 + 4 + len("map\0") + 4
    assert good[name_at:name_at + 4] == struct.pack("<I", 2)
    bad = good[:name_at] + struct.pack("<I", 0xFFFF_FFF0) + good[name_at + 4:]
    bag = write_people_bag(tmp_path / "badname", rows, raw={3: bad})
    with pytest.raises(ValueError) as e:
        cliff_lhmp.build_map(bag)
    assert str(e.value) == (
        f"tracks: {bag}: topic /people, message 3: people[0].name: length 4294967280 at "
        f"byte {name_at} runs past the end of the message ({len(good) - name_at - 4} bytes "
        "left, 1 or more per element)")
    # a NaN position (message 2, the second person)
    nan_rows = list(rows)
    nan_rows[3] = (nan_rows[3][0], nan_rows[3][1], nan_rows[3][2], math.nan, 1.0, 0.0)
    bag = write_people_bag(tmp_path / "nan", nan_rows)
    with pytest.raises(ValueError, match=r"topic /people, message 2: people\[1\]\.position\.y: "
                                         r"NaN is not a finite number"):
        cliff_lhmp.evaluate(cliff_lhmp.Map.load(THOR1_MAP), bag)
    # time going backwards: person 2 is seen at 0.8 s, then at 0.4 s
    back = [r for r in rows if not (r[1] == "2" and r[0] == "0.4")]
    back.append(("1.2", "2", 9.0, 9.0, 1.0, 0.0))
    store_rows = by_time(back)
    folder = tmp_path / "backwards"
    with writer(folder) as w:
        conn = w.add_connection("/people", PEOPLE, typestore=store)
        order = [store_rows[0], store_rows[2], store_rows[1]]  # 0.0, 0.8, 0.4 s
        for time, group in order:
            sec, ns = stamp(time)
            w.write(conn, sec * 10**9 + ns,
                    store.serialize_cdr(people_message(store, time, group), PEOPLE))
    bag = mcap_of(folder)
    err = cli_fails("map", "build", "--tracks", str(bag), "--out", str(tmp_path / "m.csv"))
    assert (f"{bag}: topic /people, message 3: header.stamp: time 0.4 of person \"1\" "
            "(person 0 of the message) is not after its previous row's (0.8)") in err


def test_big_endian_messages_are_read(tmp_path):
    store = typestore()
    rows = rows_of()
    little = tmp_path / "le"
    big = tmp_path / "be"
    for folder, ser in ((little, store.serialize_cdr), (big, None)):
        with writer(folder) as w:
            conn = w.add_connection("/people", PEOPLE, typestore=store)
            for time, group in by_time(rows):
                msg = people_message(store, time, group)
                data = (store.serialize_cdr(msg, PEOPLE, little_endian=False) if ser is None
                        else ser(msg, PEOPLE))
                sec, ns = stamp(time)
                w.write(conn, sec * 10**9 + ns, data)
    a = cliff_lhmp.build_map(mcap_of(little), grid=1.0, radius=2.0)
    b = cliff_lhmp.build_map(mcap_of(big), grid=1.0, radius=2.0)
    assert mcap_of(big).read_bytes() != mcap_of(little).read_bytes()
    np.testing.assert_array_equal(a.components, b.components)
    assert a.locations.shape[0] > 0


def test_tracked_objects_pedestrians_are_read(tmp_path):
    """autoware_perception_msgs/TrackedObjects: the objects whose most probable class is
    a pedestrian (label 7), by uuid in hex, speeds from the positions: the map of the
    CSV of those rows."""
    store = typestore()
    folder = tmp_path / "autoware"
    walker = bytes(range(16))
    second = bytes(range(100, 116))
    car = bytes([0xAB] * 16)
    csv_lines = ["t,id,x,y"]
    with writer(folder) as w:
        conn = w.add_connection("/perception/object_recognition/tracking/objects", TRACKED,
                                typestore=store)
        for k in range(12):
            time = f"{100 + k * 0.4:.1f}"
            objects = [
                (walker, [(1, 0.2), (7, 0.8)], 0.1 * k ** 1.5, 1.0 + 0.05 * k),
                (second, [(7, 0.5), (6, 0.5)], 3.0 - 0.3 * k, 0.5),  # a tie: the first wins
                (car, [(1, 0.9), (7, 0.1)], 1.0 * k, 5.0),
            ]
            if k % 3 == 0:
                objects.append((bytes([k] * 16), [], 0.0, 0.0))  # no classification
            for uuid, _, x, y in objects[:2]:
                csv_lines.append(f"{time},{uuid.hex()},{x!r},{y!r}")
            sec, ns = stamp(time)
            w.write(conn, sec * 10**9 + ns,
                    store.serialize_cdr(tracked_objects_message(store, time, objects), TRACKED))
    bag = mcap_of(folder)
    csv = tmp_path / "walkers.csv"
    csv.write_text("\n".join(csv_lines) + "\n")
    from_bag = tmp_path / "bag.csv"
    from_csv = tmp_path / "csv.csv"
    run_cli("map", "build", "--tracks", str(bag), "--grid", "0.5", "--radius", "1", "--quiet",
            "--out", str(from_bag))
    run_cli("map", "build", "--tracks", str(csv), "--format", "csv", "--grid", "0.5",
            "--radius", "1", "--quiet", "--out", str(from_csv))
    assert from_bag.read_bytes() == from_csv.read_bytes()
    assert len(from_bag.read_text().splitlines()) >= 1
    # the car (most probably not a pedestrian) and the unclassified objects were left
    # out: 24 rows of two pedestrians
    scored = cliff_lhmp.Map.load(from_bag).score(bag)
    assert scored["observations"] + scored["standing"] == 24


def test_a_bag_folder_split_in_two_files_is_one_recording(tmp_path, thor1_bag):
    rows = read_thor(THOR1_TRACKS)
    times = [t for t, _ in by_time(rows)]
    cut = Decimal(times[len(times) // 2])
    first = write_people_bag(tmp_path / "a", [r for r in rows if Decimal(r[0]) < cut])
    second = write_people_bag(tmp_path / "b", [r for r in rows if Decimal(r[0]) >= cut])
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "run_0.mcap").write_bytes(first.read_bytes())
    (folder / "run_1.mcap").write_bytes(second.read_bytes())
    (folder / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    whole = tmp_path / "whole.csv"
    split = tmp_path / "split.csv"
    run_cli("map", "build", "--tracks", str(thor1_bag), *BUILD, "--out", str(whole))
    run_cli("map", "build", "--tracks", str(folder), "--topic", "/people", *BUILD,
            "--out", str(split))
    # the people of the first file go on in the second: the same tracks, the same map
    assert split.read_bytes() == whole.read_bytes()
    # the files in the other order: the time of a person seen in both goes backwards in
    # the second file (its messages counted from 1)
    (folder / "run_0.mcap").write_bytes(second.read_bytes())
    (folder / "run_1.mcap").write_bytes(first.read_bytes())
    with pytest.raises(ValueError, match=r"run_1\.mcap: topic /people, message \d+: header\.stamp: "
                                         r"time .* is not after its previous row's"):
        cliff_lhmp.build_map(folder)
    empty = tmp_path / "empty"
    empty.mkdir()
    err = cli_fails("map", "build", "--tracks", str(empty), "--format", "rosbag2", "--out",
                    str(tmp_path / "m.csv"))
    assert f"{empty}: a folder without .mcap files" in err
