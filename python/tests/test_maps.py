"""Maps: loading, saving, arrays, building, scoring and online updates (against the CLI)."""

import json
import re

import numpy as np
import pytest

import cliff_lhmp
from conftest import DATA, THOR1_MAP, THOR1_TRACKS, run_cli

THOR3_TRACKS = DATA / "thor3" / "exp-3-run-2.csv"


def cli_info(path) -> dict:
    text = run_cli("map", "info", str(path))
    get = lambda key: re.search(rf"^{key}\s+(.*)$", text, re.M).group(1)  # noqa: E731
    return {
        "locations": int(get("locations")),
        "components": int(get("components")),
        "grid_step": float(get("grid step").split()[0]),
    }


def test_load_csv_matches_cliff_map_info(thor1_map):
    info = thor1_map.info()
    cli = cli_info(THOR1_MAP)
    assert info["locations"] == cli["locations"]
    assert info["components"] == cli["components"]
    assert info["grid_step"] == cli["grid_step"]
    (x0, y0), (x1, y1) = info["extent"]
    assert x0 < x1 and y0 < y1
    lo, hi = info["components_per_location"]
    assert 1 <= lo <= hi
    assert info["observation_ratio"][1] == 1.0
    assert info["clamped_covariances"] >= 0 and info["renormalised_locations"] >= 0


def test_arrays_describe_the_map(thor1_map):
    info = thor1_map.info()
    locs, comps, owner = thor1_map.locations, thor1_map.components, thor1_map.component_location
    assert locs.shape == (info["locations"], 2) and locs.dtype == np.float64
    assert comps.shape == (info["components"], 9)
    assert owner.shape == (info["components"],) and owner.dtype == np.int64
    np.testing.assert_array_equal(comps[:, :2], locs[owner])
    assert np.all(np.diff(owner) >= 0)
    # weights as in the file: the locations whose weights do not sum to 1 are the ones
    # `info` says were renormalised (for sampling); directions in [0, 2pi), speeds > 0
    sums = np.bincount(owner, weights=comps[:, 8])
    assert (np.abs(sums - 1) > 1e-6).sum() == info["renormalised_locations"] > 0
    assert ((comps[:, 2] >= 0) & (comps[:, 2] < 2 * np.pi)).all()
    assert (comps[:, 3] > 0).all()
    assert thor1_map.observation_ratio.shape == (info["locations"],)
    assert thor1_map.observation_ratio.max() == 1.0
    assert thor1_map.motion_ratio.shape == (info["locations"],)
    (x0, y0), (x1, y1) = info["extent"]
    assert locs[:, 0].min() == x0 and locs[:, 1].max() == y1
    # the published CSV's locations, in file order
    raw = np.loadtxt(THOR1_MAP, delimiter=",", ndmin=2)
    np.testing.assert_array_equal(comps[:, :4], raw[:, :4])
    np.testing.assert_array_equal(comps[:, 8], raw[:, 8])


@pytest.mark.parametrize("name", ["copy.csv", "copy.cliff"])
def test_save_and_load_round_trip(tmp_path, thor1_map, name):
    path = tmp_path / name
    thor1_map.save(path)
    again = cliff_lhmp.Map.load(str(path))
    np.testing.assert_array_equal(again.locations, thor1_map.locations)
    np.testing.assert_array_equal(again.components, thor1_map.components)
    np.testing.assert_array_equal(again.observation_ratio, thor1_map.observation_ratio)
    assert cli_info(path)["components"] == thor1_map.info()["components"]


def test_demo_is_the_daemons_demo():
    m = cliff_lhmp.Map.demo()
    assert m.info()["locations"] == len(m.locations) > 100
    assert "Map(locations=" in repr(m)


def test_load_errors_name_the_file_and_place(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"path: .*nope\.csv"):
        cliff_lhmp.Map.load(tmp_path / "nope.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text(THOR1_MAP.read_text().splitlines()[0] + "\n1,2,oops,4,5,6,7,8,9,10,11\n")
    with pytest.raises(ValueError, match=r"bad\.csv:2: column 3: 'oops' is not a number"):
        cliff_lhmp.Map.load(bad)
    with pytest.raises(ValueError, match="unknown map format"):
        cliff_lhmp.Map.load(tmp_path / "map.txt")
    broken = tmp_path / "broken.cliff"
    cliff_lhmp.Map.demo().save(broken)
    broken.write_bytes(broken.read_bytes()[:-10])
    with pytest.raises(ValueError, match="not a valid cliff snapshot"):
        cliff_lhmp.Map.load(broken)
    with pytest.raises(TypeError):
        cliff_lhmp.Map.load(42)  # type: ignore[arg-type]


def test_score_matches_cliff_map_score(thor1_map):
    got = thor1_map.score(THOR1_TRACKS, format="thor")
    cli = json.loads(run_cli("map", "score", "--map", str(THOR1_MAP), "--tracks", str(THOR1_TRACKS),
                             "--format", "thor", "--json"))
    assert got["observations"] == cli["observations"] > 1000
    assert got["unmatched"] == cli["unmatched"]
    assert got["standing"] == cli["standing"]
    assert got["radius"] == cli["radius"] == 0.5
    assert got["mean_log_likelihood"] == pytest.approx(cli["mean_log_likelihood"], rel=1e-12)
    assert got["median_log_likelihood"] == pytest.approx(cli["median_log_likelihood"], rel=1e-12)
    wider = thor1_map.score([str(THOR1_TRACKS)], radius=1.0)
    assert wider["unmatched"] <= got["unmatched"]


def test_build_map_matches_cliff_map_build(tmp_path):
    m = cliff_lhmp.build_map(THOR1_TRACKS, format="thor", grid=0.5, radius=0.5)
    out = tmp_path / "built.csv"
    run_cli("map", "build", "--tracks", str(THOR1_TRACKS), "--format", "thor", "--grid", "0.5",
            "--radius", "0.5", "--out", str(out))
    cli = cliff_lhmp.Map.load(out)
    np.testing.assert_array_equal(m.locations, cli.locations)
    np.testing.assert_allclose(m.components, cli.components, rtol=0, atol=1e-12)
    # a map built from THÖR1 round 2 explains THÖR1 round 2 better than the shipped one
    assert m.score(THOR1_TRACKS)["mean_log_likelihood"] > -5


def test_build_map_errors():
    with pytest.raises(FileNotFoundError, match=r"tracks: .*missing\.csv does not exist"):
        cliff_lhmp.build_map("missing.csv")
    with pytest.raises(ValueError, match="format: unknown track format 'xyz'"):
        cliff_lhmp.build_map(THOR1_TRACKS, format="xyz")
    with pytest.raises(ValueError, match="grid: -1 is not a positive number"):
        cliff_lhmp.build_map(THOR1_TRACKS, grid=-1.0)
    with pytest.raises(TypeError, match="tracks: expected a path"):
        cliff_lhmp.build_map(3.5)  # type: ignore[arg-type]


def test_online_update_matches_cliff_map_update(tmp_path, thor1_map):
    online = cliff_lhmp.OnlineMap(thor1_map, decay=0.5)
    report = online.update(THOR3_TRACKS, format="thor")
    out = tmp_path / "updated.csv"
    text = run_cli("map", "update", "--map", str(THOR1_MAP), "--tracks", str(THOR3_TRACKS),
                   "--format", "thor", "--decay", "0.5", "--out", str(out))
    assert f"observations        {report['observations']}" in text
    assert float(re.search(r"count scale out\s+(\S+)", text).group(1)) == pytest.approx(
        online.count_scale, abs=0.05)
    cli = cliff_lhmp.Map.load(out)
    now = online.map()
    np.testing.assert_array_equal(now.locations, cli.locations)
    np.testing.assert_allclose(now.components, cli.components, rtol=0, atol=1e-9)
    assert report["updated"] > 0 and len(online) == now.info()["locations"]
    # the update changed the map, and a second batch changes it again
    assert now.info()["components"] != thor1_map.info()["components"] or not np.array_equal(
        now.components, thor1_map.components)
    second = online.update(THOR1_TRACKS)
    assert second["observations"] > 0
    with pytest.raises(ValueError, match=r"decay: 0 must be in \(0, 1\]"):
        cliff_lhmp.OnlineMap(thor1_map, decay=0.0)


def test_time_of_day_sets_load_as_the_all_day_map_and_give_their_slices(tmp_path):
    # A set from two ATC training hours (unix time; Japan is UTC+9), as `cliff map build`
    # writes it, and one slice exported to CSV by the command line.
    train = [str(DATA / "atc" / "train" / f"atc-1024-{h}_train.csv") for h in (9, 19)]
    path = tmp_path / "set.cliff"
    run_cli("map", "build", "--tracks", *train, "--format", "atc", "--slice", "1h",
            "--clock-offset", "9h", "--out", str(path), "--quiet")
    run_cli("map", "convert", str(path), str(tmp_path / "h19.csv"), "--slice", "19")
    run_cli("map", "convert", str(path), str(tmp_path / "day.csv"), "--slice", "all-day")
    m = cliff_lhmp.Map.load(str(path))
    day = cliff_lhmp.Map.load(str(tmp_path / "day.csv"))
    h19 = cliff_lhmp.Map.load(str(tmp_path / "h19.csv"))
    info = m.info()
    assert (info["slices"], info["slice_length"], info["clock_offset"]) == (24, 3600.0, 32400.0)
    assert day.info()["slices"] == 0
    np.testing.assert_array_equal(m.components, day.components)
    # a timestamp of the 19:00 dev file picks the 19:00 slice; 11:00 has no slice map
    t19 = float(np.loadtxt(DATA / "atc" / "dev" / "atc-1024-19_test.csv", delimiter=",",
                           max_rows=1)[0])
    np.testing.assert_array_equal(m.slice_at(t19).components, h19.components)
    assert not np.array_equal(h19.components, day.components)
    np.testing.assert_array_equal(m.slice_at(t19 - 8 * 3600).components, day.components)
    # in UTC the same moment is 10:00: no slice map, the all-day map
    np.testing.assert_array_equal(m.slice_at(t19, clock_offset=0.0).components, day.components)
    # a slice is a plain map; a map without slices is its own slice at any time
    assert m.slice_at(t19).info()["slices"] == 0
    assert day.slice_at(t19) is day
    with pytest.raises(ValueError, match="clock_offset"):
        m.slice_at(t19, clock_offset=1e9)
    with pytest.raises(ValueError, match="time"):
        m.slice_at(float("nan"))
    # saved as a snapshot the set keeps its slices; as CSV only the all-day map
    m.save(tmp_path / "again.cliff")
    again = cliff_lhmp.Map.load(str(tmp_path / "again.cliff"))
    np.testing.assert_array_equal(again.slice_at(t19).components, h19.components)
    m.save(tmp_path / "again.csv")
    assert cliff_lhmp.Map.load(str(tmp_path / "again.csv")).info()["slices"] == 0
    # predicting with a set: `time` picks the slice (as cliffd does), "all-day" the
    # all-day map; a map without slices ignores the time
    people = np.loadtxt(DATA / "atc" / "dev" / "atc-1024-19_test.csv", delimiter=",",
                        max_rows=400)
    pid = people[0, 1]
    rows = people[people[:, 1] == pid][:6]
    hist = rows[:, [0, 2, 3]]  # t, x, y (m)
    kw = dict(k=20, dt=1.0, horizon=20.0, radius=1.0, seed=5)
    on_set = m.predict([hist], time=t19, **kw)
    on_slice = cliff_lhmp.predict(h19, [hist], **kw)
    np.testing.assert_array_equal(on_set.positions, on_slice.positions)
    all_day = m.predict([hist], time="all-day", **kw)
    np.testing.assert_array_equal(all_day.positions, day.predict([hist], **kw).positions)
    assert not np.array_equal(on_set.positions, all_day.positions, equal_nan=True)
    np.testing.assert_array_equal(day.predict([hist], time=t19, **kw).positions, all_day.positions)
