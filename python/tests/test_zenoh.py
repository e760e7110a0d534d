"""Client.connect_zenoh: a cliffd --zenoh started as a separate process on loopback.

Same bytes as in-process (and as over shared memory from the same daemon), every typed
exception (Rejected with status/field/agent/row, NoDaemon, DeadlinePassed), restarts,
bad arguments. Needs the package built with the cargo feature zenoh and a cliffd built
with it (conftest.require_zenoh says how; these tests fail without them, or skip with
the reason given in CLIFF_SKIP_ZENOH).
"""

import signal
import time

import numpy as np
import pytest

import cliff_lhmp
from conftest import (
    SERVICE,
    THOR1_MAP,
    THOR1_TRACKS,
    ZENOH_CLIFFD,
    Daemon,
    free_port,
    new_prefix,
    remove_namespace,
    require_zenoh,
)
from thor import read_people

WALK = np.array([[0.0, -10.0, 0.5], [0.4, -9.5, 0.5], [0.8, -9.0, 0.5], [1.2, -8.5, 0.5]])


def zenoh_daemon(tmp_path, maps, port, service=SERVICE, tag="z"):
    """Start `cliffd --zenoh tcp/127.0.0.1:<port>` (with its own iceoryx2 namespace)."""
    require_zenoh()
    return Daemon(new_prefix(tag), maps, tmp_path / f"cliffd-{tag}.log",
                  extra=["--zenoh", f"tcp/127.0.0.1:{port}"], exe=ZENOH_CLIFFD,
                  service=service).start()


def endpoint(port):
    return f"tcp/127.0.0.1:{port}"


@pytest.fixture(scope="module")
def remote(tmp_path_factory, demo_file):
    """One zenoh daemon for the module serving `thor1` and `demo`, and its port."""
    port = free_port()
    d = zenoh_daemon(tmp_path_factory.mktemp("zlogs"),
                     [f"thor1={THOR1_MAP}", f"demo={demo_file}"], port)
    try:
        yield d, port
    finally:
        d.stop()
        remove_namespace(d.prefix)


@pytest.fixture
def own_remote(tmp_path, demo_file):
    """A zenoh daemon for one test (to stop, kill or restart), and its port."""
    port = free_port()
    d = zenoh_daemon(tmp_path, [f"demo={demo_file}"], port, tag="zf")
    try:
        yield d, port
    finally:
        d.stop()
        remove_namespace(d.prefix)


@pytest.fixture(scope="module")
def thor1_histories():
    people = read_people(THOR1_TRACKS)
    # 30 people: (t, x, y, speed, heading) rows for some, (t, x, y) for others
    hs = [rows[:9] if i % 2 else rows[:9, :3] for i, rows in enumerate(people.values()) if len(rows) > 9]
    return hs[:30]


def same_bytes(a, b):
    """Both predictions hold the same bytes (NaN payloads included), shapes and dtypes."""
    assert a.positions.dtype == b.positions.dtype == np.float32
    assert a.lengths.dtype == b.lengths.dtype == np.int64
    assert a.positions.shape == b.positions.shape and a.lengths.shape == b.lengths.shape
    assert a.positions.tobytes() == b.positions.tobytes()
    assert a.lengths.tobytes() == b.lengths.tobytes()
    assert a.dt == b.dt


def test_zenoh_gives_the_in_process_bytes(remote, thor1_map, thor1_histories):
    d, port = remote
    client = cliff_lhmp.Client.connect_zenoh(endpoint(port), SERVICE, deadline=5.0)
    assert client.transport == "zenoh" and client.service == SERVICE
    local_client = d.client()  # the same daemon over shared memory
    assert local_client.transport == "iceoryx2"
    for seed in (0, 1, 12345):
        remote_p = client.predict("thor1", thor1_histories, k=20, seed=seed)
        local = cliff_lhmp.predict(thor1_map, thor1_histories, k=20, seed=seed)
        assert remote_p.positions.shape == (30, 20, 30, 2)
        same_bytes(remote_p, local)
        same_bytes(local_client.predict("thor1", thor1_histories, k=20, seed=seed), local)
        # the real map ends some samples early and keeps others to the horizon
        assert (local.lengths < 30).any() and (local.lengths == 30).any()
    # a different seed gives different numbers (the comparison above can tell)
    other = client.predict("thor1", thor1_histories, k=20, seed=2)
    assert other.positions.tobytes() != local.positions.tobytes()


def test_zenoh_demo_map_with_every_option(remote):
    d, port = remote
    client = cliff_lhmp.Client.connect_zenoh([endpoint(port)], deadline=5.0, service=SERVICE)
    kw = dict(k=7, dt=0.5, horizon=9.0, beta=2.0, radius=1.0, seed=4, heading="paper")
    for method in ("cliff", "cvm"):
        remote_p = client.predict("demo", [WALK, WALK[-2:]], method=method, **kw)
        local = cliff_lhmp.predict(cliff_lhmp.Map.demo(), [WALK, WALK[-2:]], method=method, **kw)
        same_bytes(remote_p, local)
        assert remote_p.dt == 0.5 and remote_p.positions.shape == (2, 7, 18, 2)


def test_zenoh_rejected_carries_status_field_agent_row(remote):
    d, port = remote
    client = cliff_lhmp.Client.connect_zenoh(endpoint(port), SERVICE, deadline=5.0)
    with pytest.raises(cliff_lhmp.Rejected) as e:
        client.predict("no-such-map", [WALK])
    assert isinstance(e.value, ValueError)
    assert (e.value.status, e.value.field, e.value.agent, e.value.row) == (
        "unknown-map", "map", None, None)
    assert "unknown-map" in str(e.value)
    with pytest.raises(cliff_lhmp.Rejected) as e:
        client.predict("demo", [WALK], k=51)  # the daemon's --max-k is 50
    assert (e.value.status, e.value.field, e.value.limit) == ("bad-k", "k", 50)
    with pytest.raises(cliff_lhmp.Rejected) as e:
        client.predict("demo", [WALK] * 33)  # --max-agents 32
    assert (e.value.status, e.value.field, e.value.limit) == ("bad-agents", "agents", 32)
    with pytest.raises(cliff_lhmp.Rejected) as e:
        client.predict("demo", [WALK, WALK, WALK[::-1].copy()])
    assert (e.value.status, e.value.field, e.value.agent, e.value.row) == (
        "history-not-increasing", "time", 2, 1)
    assert "histories[2] row 1" in str(e.value)
    # map reloads stay local: a remote client cannot trigger one
    with pytest.raises(cliff_lhmp.Rejected) as e:
        client.reload_maps()
    assert e.value.status == "unknown-kind"
    # the client still works after rejections
    p = client.predict("demo", [WALK], seed=6)
    same_bytes(p, cliff_lhmp.predict(cliff_lhmp.Map.demo(), [WALK], seed=6))


def test_zenoh_no_daemon_at_the_endpoint_or_on_the_key(tmp_path, demo_file):
    port = free_port()  # nothing listens there
    require_zenoh()
    t0 = time.monotonic()
    with pytest.raises(cliff_lhmp.NoDaemon) as e:
        cliff_lhmp.Client.connect_zenoh(endpoint(port), SERVICE, deadline=0.5)
    assert isinstance(e.value, ConnectionError)
    assert endpoint(port) in str(e.value) and SERVICE in str(e.value)
    assert time.monotonic() - t0 < 5.0
    # a daemon on another service: the link is up, but nobody answers on the key
    d = zenoh_daemon(tmp_path, [f"demo={demo_file}"], port, service="cliff/other", tag="zo")
    try:
        client = cliff_lhmp.Client.connect_zenoh(endpoint(port), SERVICE, deadline=2.0)
        t0 = time.monotonic()
        with pytest.raises(cliff_lhmp.NoDaemon):
            client.predict("demo", [WALK])
        assert time.monotonic() - t0 < 2.0  # known at once, not at the deadline
        other = cliff_lhmp.Client.connect_zenoh(endpoint(port), "cliff/other", deadline=5.0)
        assert other.predict("demo", [WALK]).positions.shape == (1, 20, 30, 2)
    finally:
        d.stop()
        remove_namespace(d.prefix)


def test_zenoh_deadline_passed_when_the_daemon_does_not_answer(own_remote):
    d, port = own_remote
    client = cliff_lhmp.Client.connect_zenoh(endpoint(port), SERVICE, deadline=0.3)
    assert client.predict("demo", [WALK]).positions.shape[0] == 1
    d.signal(signal.SIGSTOP)  # the link stays up; no answer comes
    try:
        for _ in range(2):
            t0 = time.monotonic()
            with pytest.raises(cliff_lhmp.DeadlinePassed) as e:
                client.predict("demo", [WALK])
            took = time.monotonic() - t0
            assert isinstance(e.value, TimeoutError)
            assert e.value.deadline == pytest.approx(0.3)
            assert 0.3 <= took < 2.0, took
    finally:
        d.signal(signal.SIGCONT)
    # the late answers are dropped; the next call gets its own. The daemon counts the
    # session's two stopped requests as in flight until it has answered them, so a call
    # made before that is `busy`, at once (retry once an answer has come)
    for _ in range(40):
        try:
            p = client.predict("demo", [WALK], seed=8)
            break
        except cliff_lhmp.Rejected as e:
            assert "busy" in str(e), e
            time.sleep(0.05)
    else:
        pytest.fail("still busy 2 s after the daemon resumed")
    same_bytes(p, cliff_lhmp.predict(cliff_lhmp.Map.demo(), [WALK], seed=8))


def test_zenoh_killed_daemon_then_back_on_the_same_port(own_remote):
    d, port = own_remote
    client = cliff_lhmp.Client.connect_zenoh(endpoint(port), SERVICE, deadline=0.5)
    assert client.predict("demo", [WALK]).lengths.shape == (1, 20)
    d.signal(signal.SIGKILL)
    d.proc.wait()
    d.proc = None
    # while it is down: NoDaemon (or the deadline while the link is being dropped),
    # never longer than the deadline
    for _ in range(3):
        t0 = time.monotonic()
        with pytest.raises((cliff_lhmp.NoDaemon, cliff_lhmp.DeadlinePassed)):
            client.predict("demo", [WALK])
        assert time.monotonic() - t0 < 0.5 + 1.0
    d.start()
    # the same client works again once the daemon is back
    end = time.monotonic() + 10
    while True:
        try:
            p = client.predict("demo", [WALK], seed=3)
            break
        except (cliff_lhmp.NoDaemon, cliff_lhmp.DeadlinePassed):
            assert time.monotonic() < end, "the client did not reconnect within 10 s"
            time.sleep(0.05)
    same_bytes(p, cliff_lhmp.predict(cliff_lhmp.Map.demo(), [WALK], seed=3))


def test_zenoh_bad_arguments(tmp_path):
    require_zenoh()
    Client = cliff_lhmp.Client
    with pytest.raises(TypeError, match="endpoint: expected a str"):
        Client.connect_zenoh(7447)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="endpoint: expected a str"):
        Client.connect_zenoh([b"tcp/127.0.0.1:7447"])  # type: ignore[list-item]
    with pytest.raises(ValueError, match="endpoint: empty"):
        Client.connect_zenoh("")
    with pytest.raises(ValueError, match=r"endpoint\[1\]: empty"):
        Client.connect_zenoh(["tcp/127.0.0.1:7447", " "])
    with pytest.raises(ValueError, match="needs an endpoint"):
        Client.connect_zenoh(None)
    with pytest.raises(ValueError, match="connect/endpoints"):
        Client.connect_zenoh("127.0.0.1:7447")  # no protocol
    with pytest.raises(ValueError, match="deadline: "):
        Client.connect_zenoh("tcp/127.0.0.1:7447", deadline=0.0)
    missing = tmp_path / "no-such.json5"
    with pytest.raises(FileNotFoundError, match="config: .*no-such.json5"):
        Client.connect_zenoh(None, config=missing)
    bad = tmp_path / "bad.json5"
    bad.write_text("{ mode: ")
    with pytest.raises(ValueError, match="bad.json5"):
        Client.connect_zenoh(None, config=bad)
    with pytest.raises(ValueError, match="not a zenoh key expression"):
        Client.connect_zenoh("tcp/127.0.0.1:7447", "cliff//predict")


def test_zenoh_config_file_names_the_endpoint(remote, tmp_path):
    d, port = remote
    cfg = tmp_path / "client.json5"
    cfg.write_text(f'{{ connect: {{ endpoints: ["{endpoint(port)}"] }} }}\n')
    client = cliff_lhmp.Client.connect_zenoh(None, SERVICE, config=cfg, deadline=5.0)
    p = client.predict("demo", [WALK], seed=9)
    same_bytes(p, cliff_lhmp.predict(cliff_lhmp.Map.demo(), [WALK], seed=9))
    assert repr(client) == f'Client.connect_zenoh([], service="{SERVICE}", deadline=5)'
    c2 = cliff_lhmp.Client.connect_zenoh(endpoint(port), SERVICE, deadline=0.25)
    assert repr(c2) == f'Client.connect_zenoh(["{endpoint(port)}"], service="{SERVICE}", deadline=0.25)'


def test_the_robot_loop_example_over_zenoh(remote):
    import subprocess
    import sys
    from pathlib import Path

    d, port = remote
    example = Path(__file__).parents[1] / "examples" / "robot_loop_10hz.py"
    out = subprocess.run(
        [sys.executable, str(example), "--zenoh", endpoint(port), "--service", SERVICE,
         "--seconds", "1.5", "--deadline", "2"],
        capture_output=True, text=True, timeout=60,
    )
    assert out.returncode == 0, out.stderr
    last = out.stdout.strip().splitlines()[-1]
    predicted, _, cycles = last.split(" cycles predicted")[0].partition(" of ")
    assert int(predicted) == int(cycles) >= 10, out.stdout
    assert "in 4 s person 0 " in out.stdout, out.stdout


def test_zenoh_observe_counts_each_row_once_per_session(tmp_path):
    require_zenoh()
    port = free_port()
    d = Daemon(new_prefix("zo"), [f"thor1={THOR1_MAP}"], tmp_path / "cliffd-zo.log",
               extra=["--zenoh", endpoint(port), "--learn", "thor1", "--observe-rate", "1000000"],
               exe=ZENOH_CLIFFD, service=SERVICE).start()
    try:
        client = cliff_lhmp.Client.connect_zenoh(endpoint(port), SERVICE, deadline=5.0)
        people = list(read_people(THOR1_TRACKS).values())[:10]
        for track, rows in enumerate(people):
            # a robot's overlapping histories: the first half, then all rows
            half = rows[: max(1, len(rows) // 2)]
            first = client.observe("thor1", track, half)
            second = client.observe("thor1", track, rows, end=True)
            assert first["accepted"] == len(half) and first["duplicates"] == 0
            assert second["accepted"] == len(rows) - len(half)
            assert second["duplicates"] == len(half)
        # another zenoh session is another client: its track 0 is another person
        other = cliff_lhmp.Client.connect_zenoh(endpoint(port), SERVICE, deadline=5.0)
        assert other.observe("thor1", 0, people[0])["accepted"] == len(people[0])
        with pytest.raises(cliff_lhmp.Rejected) as e:
            client.observe("elsewhere", 1, WALK)
        assert e.value.status == "unknown-map"
    finally:
        d.stop()
        remove_namespace(d.prefix)
