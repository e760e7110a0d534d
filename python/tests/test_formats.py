"""Trajectory formats recognised from the files: ``format=None`` (the default) reads each
file as the format it holds, the same as naming it; a file that could be several is an
error naming the choices."""

import numpy as np
import pytest

import cliff_lhmp
from conftest import DATA, THOR1_TRACKS, run_cli

ATC_DEV = DATA / "atc" / "dev" / "atc-1024-9_test.csv"
MAGNI = DATA / "magni" / "magni-A-first-16min.csv"


def same_map(a, b):
    assert a.info()["locations"] == b.info()["locations"]
    np.testing.assert_array_equal(a.locations, b.locations)
    np.testing.assert_array_equal(a.components, b.components)


@pytest.mark.parametrize("tracks, format", [(THOR1_TRACKS, "thor"), (ATC_DEV, "atc"),
                                            (MAGNI, "magni")])
def test_build_map_recognises_the_format(tracks, format):
    same_map(cliff_lhmp.build_map(tracks), cliff_lhmp.build_map(tracks, format=format))


def test_build_map_matches_the_cli_without_format(tmp_path):
    out = tmp_path / "thor1.csv"
    run_cli("map", "build", "--tracks", str(THOR1_TRACKS), "--out", str(out), "--quiet")
    same_map(cliff_lhmp.Map.load(out), cliff_lhmp.build_map(THOR1_TRACKS))


def test_files_of_different_formats_are_each_read_in_their_own():
    both = cliff_lhmp.build_map([THOR1_TRACKS, ATC_DEV])
    assert both.info()["locations"] > cliff_lhmp.build_map(THOR1_TRACKS).info()["locations"]


def test_score_update_and_evaluate_recognise_the_format(thor1_map):
    assert thor1_map.score(THOR1_TRACKS) == thor1_map.score(THOR1_TRACKS, format="thor")
    online = [cliff_lhmp.OnlineMap(thor1_map) for _ in range(2)]
    assert online[0].update(THOR1_TRACKS) == online[1].update(THOR1_TRACKS, format="thor")
    same_map(online[0].map(), online[1].map())
    args = dict(protocol="reference", methods=["cvm"])
    got = cliff_lhmp.evaluate(thor1_map, THOR1_TRACKS, **args)
    named = cliff_lhmp.evaluate(thor1_map, THOR1_TRACKS, format="thor", **args)
    assert got.table() == named.table()


def test_an_ambiguous_file_names_the_choices(tmp_path, thor1_map):
    either = tmp_path / "either.csv"
    either.write_text("5000000,1,0,0,1,0\n5000000.4,1,0.5,0,1.2,0\n")
    for call in (lambda: cliff_lhmp.build_map(either),
                 lambda: thor1_map.score(either),
                 lambda: cliff_lhmp.OnlineMap(thor1_map).update(either),
                 lambda: cliff_lhmp.evaluate(thor1_map, either)):
        with pytest.raises(ValueError) as e:
            call()
        msg = str(e.value)
        assert "either.csv: the format is not recognised" in msg, msg
        assert msg.endswith('give format="thor" or format="atc"'), msg
    # named, it is read
    assert thor1_map.score(either, format="atc")["observations"] == 2


def test_an_unknown_file_names_every_format(tmp_path):
    with pytest.raises(ValueError, match=r"cliffmap.csv: the format is not recognised: .*"
                       r'give format="thor", format="atc", format="magni", format="csv" '
                       r'or format="rosbag2"'):
        cliff_lhmp.build_map(DATA / "thor1" / "cliffmap.csv")
