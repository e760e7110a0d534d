"""evaluate(): the numbers of `cliff eval` on THÖR1 (the README's parity run)."""

import csv

import pytest

import cliff_lhmp
from conftest import THOR1_MAP, THOR1_TRACKS, run_cli

ARGS = dict(format="thor", protocol="reference", obs=3.2, dt=0.4, horizon=12.0,
            radius=0.7071, beta=1.0, k=20, seeds=20, methods=["cliff", "cvm"])


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def test_thor1_evaluation_matches_cliff_eval(tmp_path, thor1_map):
    out = tmp_path / "eval"
    text = run_cli(
        "eval", "--map", str(THOR1_MAP), "--tracks", str(THOR1_TRACKS), "--format", "thor",
        "--protocol", "reference", "--obs", "3.2", "--dt", "0.4", "--horizon", "12",
        "--radius", "0.7071", "--beta", "1", "--k", "20", "--seeds", "20",
        "--methods", "cliff,cvm", "--out", str(out),
    )
    r = cliff_lhmp.evaluate(thor1_map, THOR1_TRACKS, **ARGS)
    assert f"{r.people_evaluated} of {r.people_total} people evaluated" in text
    assert (r.people_evaluated, r.people_total) == (62, 87)  # the reference's counts
    summary = read_csv(out / "summary.csv")
    assert len(r.summary) == len(summary) == 60  # 2 methods x 30 steps
    for got, want in zip(r.summary, summary):
        assert got["method"] == want["method"] and f"{got['horizon']:.1f}" == want["horizon"]
        assert got["seeds"] == int(want["seeds"])
        assert got["people"] == pytest.approx(float(want["people"]), abs=1e-9)
        for key in ("ade", "fde", "min_ade", "min_fde", "ade_sd", "fde_sd", "min_ade_sd",
                    "min_fde_sd"):
            assert got[key] == pytest.approx(float(want[key]), abs=6e-7), key
        assert got["reach"] == pytest.approx(float(want["reach"]), abs=6e-5)
    per_person = read_csv(out / "per_person.csv")
    assert len(r.per_person) == len(per_person) > 1000
    for got, want in zip(r.per_person, per_person):
        assert got["person_id"] == int(want["person_id"]) and got["method"] == want["method"]
        for key in ("ade", "fde", "min_ade", "min_fde"):
            assert got[key] == pytest.approx(float(want[key]), abs=6e-7), key
        assert got["samples_reaching"] == pytest.approx(float(want["samples_reaching"]))
    # the printed table is the CLI's
    table = r.table()
    for line in table.splitlines()[1:]:
        assert line in text
    # close to the published implementation's figures (cliff-lhmp-reference.md)
    at2 = next(s for s in r.summary if s["method"] == "cliff" and abs(s["horizon"] - 2.0) < 1e-9)
    assert at2["ade"] == pytest.approx(0.319, rel=0.03)


def test_tables_are_lists_of_dicts_for_pandas(thor1_map):
    r = cliff_lhmp.evaluate(thor1_map, [THOR1_TRACKS], protocol="seconds", seeds=2,
                            methods=["cvm"], horizon=4.0)
    assert isinstance(r.summary, list) and all(isinstance(d, dict) for d in r.summary)
    assert {d["method"] for d in r.summary} == {"cvm"}
    assert max(d["horizon"] for d in r.summary) == pytest.approx(4.0)
    pd = pytest.importorskip("pandas")
    frame = pd.DataFrame(r.summary)
    assert list(frame.columns)[:3] == ["method", "horizon", "people"]


@pytest.mark.parametrize(
    "kwargs,exc,match",
    [
        (dict(protocol="fancy"), ValueError, "protocol: "),
        (dict(methods=["cliff", "oracle"]), ValueError, "methods: unknown method 'oracle'"),
        (dict(methods=[]), ValueError, "methods: names no method"),
        (dict(seeds=0), ValueError, "seeds: 0 must be at least 1"),
        (dict(k=0), ValueError, "k: 0 must be at least 1"),
        (dict(dt=-0.4), ValueError, "dt: -0.4 is not a positive number"),
        (dict(format="parquet"), ValueError, "format: unknown track format"),
        (dict(count="some"), ValueError, "count: unknown counting 'some'"),
        (dict(max_speed=-2.5), ValueError, "max_speed: -2.5 is not a positive speed"),
    ],
)
def test_bad_arguments(thor1_map, kwargs, exc, match):
    with pytest.raises(exc, match=match):
        cliff_lhmp.evaluate(thor1_map, THOR1_TRACKS, **kwargs)


def test_missing_track_file(thor1_map, tmp_path):
    with pytest.raises(FileNotFoundError, match="tracks: .*gone.csv does not exist"):
        cliff_lhmp.evaluate(thor1_map, tmp_path / "gone.csv")


def test_tracklets_count_everyone_and_the_map_free_methods_match_cliff_eval(tmp_path, thor1_map):
    # THÖR1's people cut as the THÖR-MAGNI benchmark cuts its recordings
    args = dict(format="thor", protocol="tracklets", obs=3.2, dt=0.4, horizon=4.8, seeds=2,
                methods=["cliff", "cvm-last", "motion"], count="everyone", max_speed=3.0)
    r = cliff_lhmp.evaluate(thor1_map, THOR1_TRACKS, **args)
    out = tmp_path / "eval"
    text = run_cli(
        "eval", "--map", str(THOR1_MAP), "--tracks", str(THOR1_TRACKS), "--format", "thor",
        "--protocol", "tracklets", "--obs-rows", "8", "--pred-rows", "12", "--seeds", "2",
        "--methods", "cliff,cvm-last,motion", "--count", "everyone", "--max-speed", "3",
        "--out", str(out),
    )
    assert f"{r.people_evaluated} tracklets of {r.people_total} people evaluated" in text
    last = {d["method"]: d for d in r.summary if d["horizon"] == pytest.approx(4.8)}
    # every method over the same tracklets; the paper's samples stop, the others do not
    assert last["cliff"]["people"] == last["cvm-last"]["people"] == last["motion"]["people"]
    assert last["motion"]["reach"] == 1.0 and last["cliff"]["reach"] < 1.0
    want = {row["method"]: row for row in read_csv(out / "summary.csv") if row["horizon"] == "4.8"}
    for m in ("cliff", "cvm-last", "motion"):
        assert last[m]["top1_ade"] == pytest.approx(float(want[m]["top1_ade"]), abs=6e-7)
