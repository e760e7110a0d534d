"""In-process prediction: same numbers as the Rust predictor, shapes, NaN, errors."""

import csv
import threading
import time

import numpy as np
import pytest

import cliff_lhmp
from conftest import THOR1_MAP, THOR1_TRACKS, run_cli
from thor import person_seed, read_people, start_row

WALK = np.array([[0.0, -10.0, 0.5], [0.4, -9.5, 0.5], [0.8, -9.0, 0.5], [1.2, -8.5, 0.5]])


@pytest.fixture(scope="module")
def people():
    return read_people(THOR1_TRACKS)


@pytest.mark.parametrize("person,seed", [(12002, 3), (12004, 0), (12004, 7)])
def test_same_numbers_as_cliff_predict(tmp_path, thor1_map, people, person, seed):
    out = tmp_path / "pred.csv"
    run_cli(
        "predict", "--map", str(THOR1_MAP), "--tracks", str(THOR1_TRACKS), "--format", "thor",
        "--protocol", "reference", "--person", str(person), "--seed", str(seed), "--out", str(out),
    )
    with open(out) as f:
        rows = list(csv.DictReader(f))
    steps = max(int(r["step"]) for r in rows)
    (t, x, y), speed, heading = start_row(people[person])
    # one row with the tracker's speed and heading gives exactly that start velocity
    history = np.array([[t, x, y, speed, heading]])
    p = cliff_lhmp.predict(
        thor1_map, [history], k=20, dt=0.4, horizon=steps * 0.4, radius=0.7071067811865476,
        beta=1.0, seed=person_seed(seed, person),
    )
    assert p.positions.shape == (1, 20, steps, 2)
    want = np.full((20, steps, 2), np.nan)
    lengths = np.zeros(20, dtype=np.int64)
    for r in rows:
        s, j = int(r["sample"]), int(r["step"]) - 1
        want[s, j] = (float(r["x"]), float(r["y"]))
        lengths[s] = max(lengths[s], j + 1)
    np.testing.assert_array_equal(p.lengths[0], lengths)
    # `cliff predict` prints 4 decimals
    np.testing.assert_allclose(p.positions[0], want, atol=6e-5, rtol=0)
    if person == 12004:
        assert (lengths < steps).any(), "this person has samples that end early"


def test_shapes_dtypes_and_nan_after_the_end(thor1_map, people):
    (t, x, y), speed, heading = start_row(people[12004])
    hist = np.array([[t, x, y, speed, heading]])
    two_rows = people[12004][7:9, :3]
    p = cliff_lhmp.predict(thor1_map, [hist, two_rows, WALK], k=20, horizon=12.0)
    assert p.positions.dtype == np.float32 and p.lengths.dtype == np.int64
    assert p.positions.shape == (3, 20, 30, 2) and p.lengths.shape == (3, 20)
    assert (p.agents, p.k, p.steps, len(p)) == (3, 20, 30, 3)
    for a in range(3):
        for s in range(20):
            n = p.lengths[a, s]
            assert np.isfinite(p.positions[a, s, :n]).all()
            assert np.isnan(p.positions[a, s, n:]).all()
            np.testing.assert_array_equal(p.sample(a, s), p.positions[a, s, :n])
    assert (p.lengths[0] < 30).any()
    # the WALK person is far from every THÖR1 location: its samples end at once
    assert (p.lengths[2] == 0).all()
    with pytest.raises(IndexError, match="agent"):
        p.sample(3, 0)


def test_seed_decides_the_samples():
    m = cliff_lhmp.Map.demo()
    a = cliff_lhmp.predict(m, [WALK], seed=5)
    b = cliff_lhmp.predict(m, [WALK], seed=5)
    c = cliff_lhmp.predict(m, [WALK], seed=6)
    top = cliff_lhmp.predict(m, [WALK], seed=2**64 - 1)
    assert np.isfinite(top.positions[0, 0, 0]).all()
    np.testing.assert_array_equal(a.positions, b.positions)
    assert not np.array_equal(a.positions, c.positions, equal_nan=True)


def test_constant_velocity_walks_straight_on():
    p = cliff_lhmp.predict(cliff_lhmp.Map.demo(), [WALK], method="cvm", k=3, horizon=2.0)
    # 0.5 m per 0.4 s along x, from the last row (-8.5, 0.5)
    want_x = -8.5 + 0.5 * np.arange(1, 6)
    for s in range(3):
        np.testing.assert_allclose(p.positions[0, s, :, 0], want_x, atol=1e-5)
        np.testing.assert_allclose(p.positions[0, s, :, 1], 0.5, atol=1e-5)
    assert (p.lengths == 5).all()


def test_inputs_that_numpy_can_convert_give_the_same_numbers():
    m = cliff_lhmp.Map.demo()
    ref = cliff_lhmp.predict(m, [WALK, WALK + [0, 0, 1]], seed=1)
    stacked = np.stack([WALK, WALK + [0, 0, 1]])  # one 3-D array
    wide = np.zeros((4, 6))
    wide[:, ::2] = WALK  # a strided view
    for histories in (
        stacked,
        [WALK.tolist(), (WALK + [0, 0, 1]).tolist()],
        [WALK, np.asfortranarray(WALK + [0, 0, 1])],
        (wide[:, ::2], WALK + [0, 0, 1]),
    ):
        p = cliff_lhmp.predict(m, histories, seed=1)
        np.testing.assert_array_equal(p.positions, ref.positions)
    # other dtypes are converted to float64
    w32 = WALK.astype(np.float32)
    np.testing.assert_array_equal(
        cliff_lhmp.predict(m, [w32], seed=1).positions,
        cliff_lhmp.predict(m, [w32.astype(np.float64)], seed=1).positions,
    )


def test_only_the_last_64_rows_count():
    m = cliff_lhmp.Map.demo()
    t = np.arange(100) * 0.4
    long = np.stack([t, -20 + 0.5 * np.arange(100) / 4, 0.5 + 0.01 * np.sin(t)], axis=1)
    a = cliff_lhmp.predict(m, [long], seed=2)
    b = cliff_lhmp.predict(m, [long[-64:]], seed=2)
    np.testing.assert_array_equal(a.positions, b.positions)


def test_many_people_in_one_call(thor1_map, people):
    hists = []
    for rows in people.values():
        if len(rows) > 9:
            hists.append(rows[:9])
    batch = (hists * 40)[:2000]
    p = cliff_lhmp.predict(thor1_map, batch, k=20, seed=9)
    assert p.positions.shape == (2000, 20, 30, 2)
    # the same person in one call twice gets other draws, but the same start
    n = len(hists)
    assert not np.array_equal(p.positions[0], p.positions[n], equal_nan=True)
    assert (p.lengths >= 0).all() and (p.lengths <= 30).all()
    assert (p.lengths > 0).mean() > 0.5


@pytest.mark.parametrize(
    "histories,kwargs,exc,match",
    [
        ([np.zeros(3)], {}, ValueError, r"histories\[0\]: expected a 2-D array"),
        ([WALK, np.zeros((3, 4))], {}, ValueError, r"histories\[1\]: expected rows of 3 columns"),
        ([np.zeros((0, 3))], {}, ValueError, r"histories\[0\]: has no rows"),
        ([WALK[:1]], {}, ValueError, r"histories\[0\]: too few rows"),
        ([WALK[::-1].copy()], {}, ValueError, r"histories\[0\] row 1 t \(column 0\): times must strictly increase"),
        ([np.where(np.arange(12).reshape(4, 3) == 7, np.nan, WALK)], {}, ValueError,
         r"histories\[0\] row 2 x \(column 1\): NaN is not a finite number"),
        ([np.array([[0.0, 1.0, 2.0, np.inf, 0.0]])], {}, ValueError, r"histories\[0\] row 0 speed"),
        ([np.array([[0.0, 1.0, 2.0, -1.0, 0.0]])], {}, ValueError, r"histories\[0\] row 0 speed \(column 3\): is out of range"),
        ([[["a", "b", "c"]]], {}, TypeError, r"histories\[0\]: cannot be read as an array of numbers"),
        ([], {}, ValueError, r"histories: is empty"),
        ("abc", {}, TypeError, r"histories: expected a sequence"),
        (5, {}, TypeError, r"histories: expected a sequence"),
        ([WALK], {"method": "magic"}, ValueError, r"method: unknown method 'magic'"),
        ([WALK], {"heading": "sideways"}, ValueError, r"heading: unknown heading rule"),
        ([WALK], {"k": 0}, ValueError, r"k: 0 samples"),
        ([WALK], {"k": -3}, ValueError, r"k: -3 samples"),
        ([WALK], {"seed": -1}, ValueError, r"seed: -1 is not between 0 and 2\*\*64 - 1"),
        ([WALK], {"seed": 2**64}, ValueError, r"seed: 18446744073709551616 is not between"),
        ([WALK], {"dt": 0.0}, ValueError, r"dt: 0 is not a positive number"),
        ([WALK], {"dt": float("nan")}, ValueError, r"dt: NaN is not a positive number"),
        ([WALK], {"horizon": 0.1}, ValueError, r"horizon: 0.1 s is less than one step"),
        ([WALK], {"radius": -1.0}, ValueError, r"radius: -1 is not a positive number"),
        ([WALK], {"beta": float("inf")}, ValueError, r"beta: inf is not a non-negative number"),
        ([WALK], {"speed_beta": float("nan")}, ValueError, r"speed_beta: is NaN or infinite"),
        ([WALK], {"speed_beta": -1.0}, ValueError, r"speed_beta: is out of range"),
        ([WALK], {"coast": -1.0}, ValueError, r"coast: is out of range \(coast must be between 0 and the horizon\)"),
        ([WALK], {"coast": 12.5}, ValueError, r"coast: is out of range"),
        ([WALK], {"time": float("nan")}, ValueError, r"time: is NaN or infinite"),
        ([WALK], {"time": "yesterday"}, ValueError, r'time: unknown time "yesterday"'),
        ([WALK], {"time": True}, TypeError, r"time: expected None, seconds or \"all-day\", got a bool"),
        ([WALK], {"time": [1.0]}, TypeError, r"time: expected None, seconds or \"all-day\", got list"),
        ([WALK], {"method": "improve"}, ValueError, r"method: unknown method 'improve'"),
    ],
)
def test_bad_input_names_the_argument(histories, kwargs, exc, match):
    with pytest.raises(exc, match=match):
        cliff_lhmp.predict(cliff_lhmp.Map.demo(), histories, **kwargs)


def test_a_batch_too_large_for_memory_is_a_memory_error():
    with pytest.raises(MemoryError, match="4000000000 samples x 30 steps is too large"):
        cliff_lhmp.predict(cliff_lhmp.Map.demo(), [WALK] * 1000, k=4_000_000_000)


def test_positions_are_handed_over_without_a_copy():
    p = cliff_lhmp.predict(cliff_lhmp.Map.demo(), [WALK], k=2)
    assert p.positions.base is not None and p.positions.flags.c_contiguous
    assert p.positions is p.positions  # the same array on every access


def test_map_must_be_a_map():
    with pytest.raises(TypeError):
        cliff_lhmp.predict("demo", [WALK])  # type: ignore[arg-type]


def test_the_gil_is_released_while_rust_predicts(thor1_map, people):
    """A Python thread keeps running while another thread is inside predict()."""
    hist = [rows[:9] for rows in people.values() if len(rows) > 9]
    batch = (hist * 400)[:20000]
    inside = threading.Event()
    done = threading.Event()
    took = []

    def work():
        inside.set()
        t0 = time.perf_counter()
        cliff_lhmp.predict(thor1_map, batch, k=20, horizon=12.0)
        took.append(time.perf_counter() - t0)
        done.set()

    # how fast this loop counts on its own
    stop = time.perf_counter() + 0.05
    alone = 0
    while time.perf_counter() < stop:
        alone += 1
    rate = alone / 0.05

    worker = threading.Thread(target=work)
    worker.start()
    inside.wait()
    count = 0
    while not done.is_set():
        count += 1
    worker.join()
    # With the GIL held for the whole call this thread would get at most a switch
    # interval or two (5 ms each) of the call; released, it counts all along (sharing
    # the machine with the worker and other processes).
    assert took[0] > 0.1, f"the call took only {took[0]:.3f} s: make the batch larger"
    assert count > 0.1 * rate * took[0], (
        f"{count} counts during a {took[0]:.3f} s call; alone {rate:.0f} per s"
    )


def test_scores_rank_the_samples_and_come_with_the_improved_method(thor1_map, people):
    hs = [rows[:9] for rows in list(people.values())[:8] if len(rows) > 9]
    plain = cliff_lhmp.predict(thor1_map, hs, k=20, seed=3)
    assert plain.scores is None and plain.best_sample(0) is None
    p = cliff_lhmp.predict(thor1_map, hs, k=20, seed=3, scores=True)
    # scores do not change the samples
    np.testing.assert_array_equal(p.positions, plain.positions)
    np.testing.assert_array_equal(p.lengths, plain.lengths)
    assert p.scores.dtype == np.float32 and p.scores.shape == (len(hs), 20)
    assert np.isfinite(p.scores).all() and len(np.unique(p.scores)) > 1
    for a in range(len(hs)):
        assert p.best_sample(a) == int(np.argmax(p.scores[a]))
    assert len({p.best_sample(a) for a in range(len(hs))}) > 1
    with pytest.raises(IndexError, match="agent: 99"):
        p.best_sample(99)
    assert "scores" in repr(p)
    # the improved method scores its samples, asked or not
    q = cliff_lhmp.predict(thor1_map, hs, k=20, seed=3, method="improved")
    assert q.scores is not None and q.scores.shape == (len(hs), 20)


def test_coasting_keeps_samples_going_where_the_map_ends(thor1_map, people):
    (t, x, y), speed, heading = start_row(people[12004])
    hist = np.array([[t, x, y, speed, heading]])
    paper = cliff_lhmp.predict(thor1_map, [hist], k=20, seed=0)
    assert (paper.lengths < 30).any(), "this person has samples that end early"
    coasting = cliff_lhmp.predict(thor1_map, [hist], k=20, seed=0, coast=12.0)
    assert (coasting.lengths == 30).all()
    assert np.isfinite(coasting.positions).all()
    # the speed kernel changes the samples
    speedy = cliff_lhmp.predict(thor1_map, [hist], k=20, seed=0, speed_beta=2.0)
    assert not np.array_equal(speedy.positions, paper.positions, equal_nan=True)


def test_time_is_checked_and_one_map_serves_every_time():
    m = cliff_lhmp.Map.demo()
    runs = [
        cliff_lhmp.predict(m, [WALK], k=5, seed=2, time=t)
        for t in (None, "now", 1_351_771_200.0, 0, "all-day", "ALL-DAY")
    ]
    for r in runs[1:]:
        np.testing.assert_array_equal(r.positions, runs[0].positions)


def test_cvm_last_and_motion_read_the_observed_rows(thor1_map):
    # east at 1.25 m/s, then the last step turned north
    turned = np.array([[0.0, 0.0, 0.0], [0.4, 0.5, 0.0], [0.8, 1.0, 0.0], [1.2, 1.0, 0.5]])
    p = cliff_lhmp.predict(thor1_map, [turned], k=1, dt=0.4, horizon=2.0, method="cvm-last")
    # constant velocity of the last displacement: north at 1.25 m/s from (1, 0.5)
    want = np.array([[1.0, 0.5 + 0.5 * j] for j in range(1, 6)])
    np.testing.assert_allclose(p.positions[0, 0], want, atol=1e-5)
    m = cliff_lhmp.predict(thor1_map, [WALK], k=5, dt=0.4, horizon=12.0, method="motion")
    # the learned model needs no map: every sample reaches the horizon, going on east
    assert not np.isnan(m.positions).any()
    assert (m.positions[0, 0, -1, 0] > WALK[-1, 1] + 5.0)
