"""The cliffd client: same numbers as in-process, every exception class, restarts."""

import pickle
import signal
import threading
import time

import numpy as np
import pytest

import cliff_lhmp
from conftest import SERVICE, THOR1_MAP, THOR1_TRACKS, Daemon, new_prefix, remove_namespace
from thor import read_people

WALK = np.array([[0.0, -10.0, 0.5], [0.4, -9.5, 0.5], [0.8, -9.0, 0.5], [1.2, -8.5, 0.5]])


@pytest.fixture(scope="module")
def thor1_histories():
    people = read_people(THOR1_TRACKS)
    # 30 people: (t, x, y, speed, heading) rows for some, (t, x, y) for others
    hs = [rows[:9] if i % 2 else rows[:9, :3] for i, rows in enumerate(people.values()) if len(rows) > 9]
    return hs[:30]


def test_daemon_gives_the_in_process_numbers(daemon, thor1_map, thor1_histories):
    client = daemon.client()
    for seed in (0, 1, 12345):
        remote = client.predict("thor1", thor1_histories, k=20, seed=seed)
        local = cliff_lhmp.predict(thor1_map, thor1_histories, k=20, seed=seed)
        assert remote.positions.shape == (30, 20, 30, 2)
        assert remote.positions.dtype == np.float32 and remote.lengths.dtype == np.int64
        np.testing.assert_array_equal(remote.lengths, local.lengths)
        np.testing.assert_array_equal(remote.positions, local.positions)  # NaN == NaN here
        assert (local.lengths < 30).any() and (local.lengths > 0).any()


def test_daemon_demo_map_with_every_option(daemon):
    client = daemon.client(wait="spin")
    kw = dict(k=7, dt=0.5, horizon=9.0, beta=2.0, radius=1.0, seed=4, heading="paper")
    for method in ("cliff", "cvm"):
        remote = client.predict("demo", [WALK, WALK[-2:]], method=method, **kw)
        local = cliff_lhmp.predict(cliff_lhmp.Map.demo(), [WALK, WALK[-2:]], method=method, **kw)
        np.testing.assert_array_equal(remote.positions, local.positions)
        np.testing.assert_array_equal(remote.lengths, local.lengths)
        assert remote.dt == 0.5 and remote.positions.shape == (2, 7, 18, 2)


def test_daemon_options_scores_and_time_give_the_in_process_numbers(daemon, thor1_map, thor1_histories):
    client = daemon.client()
    cases = [
        dict(method="cliff", scores=True),
        dict(method="cliff", speed_beta=2.0, coast=6.0, scores=True, time="all-day"),
        dict(method="cvm", scores=True, time=1_351_771_200.0),
        dict(method="improved"),
        dict(method="improved", scores=True, coast=3.0),
        dict(method="cliff", speed_beta=1.0, coast=12.0),
    ]
    for i, kw in enumerate(cases):
        # the daemon's limits count improved as 3 requests (pruned candidates, follow):
        # at k 20 and 30 steps it takes at most 88 people
        hs = thor1_histories[:20] if kw["method"] == "improved" else thor1_histories
        remote = client.predict("thor1", hs, k=20, seed=i, **kw)
        local = cliff_lhmp.predict(thor1_map, hs, k=20, seed=i, **kw)
        np.testing.assert_array_equal(remote.lengths, local.lengths)
        np.testing.assert_array_equal(remote.positions, local.positions)
        scored = kw.get("scores", False) or kw["method"] == "improved"
        if scored:
            assert remote.scores.shape == (len(hs), 20) and remote.scores.dtype == np.float32
            # bit for bit
            np.testing.assert_array_equal(remote.scores.view(np.uint32), local.scores.view(np.uint32))
            assert remote.best_sample(3) == local.best_sample(3) == int(np.argmax(local.scores[3]))
        else:
            assert remote.scores is None and local.scores is None


def test_rejected_names_the_new_fields(daemon):
    client = daemon.client()
    for kw, status, field in [
        (dict(speed_beta=-1.0), "bad-value", "speed_beta"),
        (dict(speed_beta=float("inf")), "non-finite", "speed_beta"),
        (dict(coast=13.0), "bad-value", "coast"),
        (dict(time=float("nan")), "non-finite", "time"),
    ]:
        with pytest.raises(cliff_lhmp.Rejected) as e:
            client.predict("demo", [WALK], **kw)
        assert (e.value.status, e.value.field) == (status, field), kw
        assert field in str(e.value)


def test_rejected_carries_status_and_field(daemon):
    client = daemon.client()
    with pytest.raises(cliff_lhmp.Rejected) as e:
        client.predict("no-such-map", [WALK])
    assert isinstance(e.value, ValueError)
    assert (e.value.status, e.value.field) == ("unknown-map", "map")
    assert "unknown-map" in str(e.value) and "map" in str(e.value)
    with pytest.raises(cliff_lhmp.Rejected) as e:
        client.predict("demo", [WALK], k=51)  # the daemon's --max-k is 50
    assert (e.value.status, e.value.field, e.value.limit) == ("bad-k", "k", 50)
    with pytest.raises(cliff_lhmp.Rejected) as e:
        client.predict("demo", [WALK] * 33)  # --max-agents 32
    assert (e.value.status, e.value.field, e.value.limit) == ("bad-agents", "agents", 32)
    with pytest.raises(cliff_lhmp.Rejected) as e:
        client.predict("demo", [WALK, WALK[::-1].copy()])
    assert (e.value.status, e.value.field, e.value.agent, e.value.row) == (
        "history-not-increasing", "time", 1, 1)
    assert "histories[1] row 1" in str(e.value)
    # the client still works after rejections
    assert client.predict("demo", [WALK]).positions.shape == (1, 20, 30, 2)


def test_bad_arguments_are_caught_before_sending(daemon):
    client = daemon.client()
    with pytest.raises(ValueError, match=r"histories\[0\] row 0 x \(column 1\)"):
        client.predict("demo", [np.array([[0.0, np.nan, 0.0, 1.0, 0.0]])])
    with pytest.raises(ValueError, match="method: unknown method"):
        client.predict("demo", [WALK], method="teleport")
    with pytest.raises(ValueError, match="map: "):
        client.predict("x" * 200, [WALK])
    with pytest.raises(ValueError, match="wait: unknown wait mode"):
        daemon.client(wait="sometimes")
    with pytest.raises(ValueError, match="deadline: "):
        daemon.client(deadline=-1.0)


def test_no_daemon_is_a_connection_error():
    prefix = new_prefix("none")
    try:
        with pytest.raises(cliff_lhmp.NoDaemon) as e:
            cliff_lhmp.Client(SERVICE, prefix=prefix)
        assert isinstance(e.value, ConnectionError)
        assert SERVICE in str(e.value)
    finally:
        remove_namespace(prefix)


def test_deadline_passed_is_a_timeout_error(own_daemon):
    client = own_daemon.client(deadline=0.2, wait="block")
    assert client.predict("demo", [WALK]).positions.shape[0] == 1
    own_daemon.signal(signal.SIGSTOP)
    try:
        t0 = time.monotonic()
        with pytest.raises(cliff_lhmp.DeadlinePassed) as e:
            client.predict("demo", [WALK])
        assert isinstance(e.value, TimeoutError)
        assert e.value.deadline == pytest.approx(0.2)
        assert time.monotonic() - t0 < 2.0
    finally:
        own_daemon.signal(signal.SIGCONT)
    # the late answer to the first request is dropped; the next call gets its own
    p = client.predict("demo", [WALK], seed=8)
    q = cliff_lhmp.predict(cliff_lhmp.Map.demo(), [WALK], seed=8)
    np.testing.assert_array_equal(p.positions, q.positions)


def test_daemon_gone_mid_request_then_back_after_a_restart(own_daemon):
    client = own_daemon.client(deadline=20.0, wait="block")
    assert client.predict("demo", [WALK]).lengths.shape == (1, 20)
    own_daemon.signal(signal.SIGSTOP)  # the request will be in flight
    result = {}

    def call():
        try:
            client.predict("demo", [WALK])
            result["ok"] = True
        except Exception as e:  # noqa: BLE001 - the test inspects it
            result["error"] = e

    th = threading.Thread(target=call)
    th.start()
    time.sleep(0.3)
    own_daemon.signal(signal.SIGKILL)
    th.join(25)
    assert not th.is_alive()
    err = result.get("error")
    assert isinstance(err, cliff_lhmp.DaemonGone), result
    assert isinstance(err, ConnectionError)
    own_daemon.proc.wait()
    own_daemon.proc = None
    # with no daemon: NoDaemon (or DaemonGone while the dead one is being cleaned up)
    with pytest.raises((cliff_lhmp.NoDaemon, cliff_lhmp.DaemonGone)):
        client.predict("demo", [WALK])
    own_daemon.start()
    # the same client works again once the daemon is back
    deadline = time.monotonic() + 10
    while True:
        try:
            p = client.predict("demo", [WALK], seed=3)
            break
        except (cliff_lhmp.NoDaemon, cliff_lhmp.DaemonGone):
            assert time.monotonic() < deadline, "the client did not recover"
            time.sleep(0.05)
    q = cliff_lhmp.predict(cliff_lhmp.Map.demo(), [WALK], seed=3)
    np.testing.assert_array_equal(p.positions, q.positions)


def test_reload_maps(tmp_path):
    path = tmp_path / "hall.csv"
    cliff_lhmp.Map.demo().save(path)
    prefix = new_prefix("r")
    d = Daemon(prefix, [f"hall={path}"], tmp_path / "cliffd.log").start()
    try:
        client = d.client()
        before = client.predict("hall", [WALK], seed=1)
        # a map with every location moved 1 m in y: other samples
        csv = np.loadtxt(path, delimiter=",", ndmin=2)
        csv[:, 1] += 1.0
        moved = tmp_path / "moved.csv"
        np.savetxt(moved, csv, delimiter=",", fmt="%.17g")
        moved.replace(path)
        client.reload_maps()
        after = client.predict("hall", [WALK], seed=1)
        local = cliff_lhmp.predict(cliff_lhmp.Map.load(path), [WALK], seed=1)
        np.testing.assert_array_equal(after.positions, local.positions)
        assert not np.array_equal(after.positions, before.positions, equal_nan=True)
        path.write_text("not,a,map\n")
        with pytest.raises(cliff_lhmp.Rejected) as e:
            client.reload_maps()
        assert e.value.status == "reload-failed"
        # the map keeps its last good version
        again = client.predict("hall", [WALK], seed=1)
        np.testing.assert_array_equal(again.positions, after.positions)
    finally:
        d.stop()
        remove_namespace(prefix)


def test_exceptions_pickle_with_their_attributes():
    r = cliff_lhmp.Rejected("msg", "bad-k", "k", None, None, 50)
    r2 = pickle.loads(pickle.dumps(r))
    assert (str(r2), r2.status, r2.field, r2.limit) == ("msg", "bad-k", "k", 50)
    d = pickle.loads(pickle.dumps(cliff_lhmp.DeadlinePassed("late", 0.05)))
    assert d.deadline == 0.05 and isinstance(d, TimeoutError)
    assert issubclass(cliff_lhmp.NoDaemon, ConnectionError)
    assert issubclass(cliff_lhmp.DaemonGone, ConnectionError)
    assert issubclass(cliff_lhmp.Rejected, ValueError)


def test_observe_counts_each_row_once_and_predictions_name_the_learned_version(tmp_path):
    prefix = new_prefix("l")
    d = Daemon(prefix, [f"thor1={THOR1_MAP}"], tmp_path / "cliffd.log",
               extra=["--learn", "thor1", "--observe-rate", "1000000", "--learn-every-s", "0.3",
                      "--learn-held-rows", "0"]).start()
    try:
        client = d.client()
        people = list(read_people(THOR1_TRACKS).values())
        total = 0
        for track, rows in enumerate(people):
            # a robot's overlapping histories: the first half, then all rows (5 columns)
            half = rows[: max(1, len(rows) // 2)]
            first = client.observe("thor1", track, half)
            second = client.observe("thor1", track, rows, end=True)
            assert first["accepted"] == len(half) and first["duplicates"] == 0
            assert second["accepted"] == len(rows) - len(half)
            assert second["duplicates"] == len(half)
            total += len(rows)
        assert total > 1000
        # positions only (3 columns) are taken as well
        assert client.observe("thor1", 10_000, people[0][:, :3])["accepted"] == len(people[0])
        with pytest.raises(cliff_lhmp.Rejected) as e:
            client.observe("elsewhere", 1, WALK)
        assert e.value.status == "unknown-map"
        with pytest.raises(ValueError, match=r"got shape \(3, 4\)"):
            client.observe("thor1", 1, np.zeros((3, 4)))
        # the learned version comes within the learning interval
        deadline = time.monotonic() + 20
        version = 0
        while version == 0:
            assert time.monotonic() < deadline, "no learned version within 20 s"
            time.sleep(0.1)
            version = client.observe("thor1", 20_000, WALK)["map_version"]
        assert version >= 1
        # predictions name the version that answered; in-process ones the map as loaded
        near = people[0][:3, :3]
        assert client.predict("thor1", [near], k=4).map_version >= version
        local = cliff_lhmp.predict(cliff_lhmp.Map.load(THOR1_MAP), [near], k=4)
        assert local.map_version == 0
    finally:
        d.stop()
        remove_namespace(prefix)
