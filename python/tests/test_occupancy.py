"""Occupancy from a prediction: shapes, the normal mass of a cell against math.erf, the
window against the times within it, the path check on a known path, errors."""

import math

import numpy as np
import pytest

import cliff_lhmp

# walking east at 1.25 m/s along y = 0.5 in the demo hall
WALK = np.array([[0.0, -10.0, 0.5], [0.4, -9.5, 0.5], [0.8, -9.0, 0.5], [1.2, -8.5, 0.5]])
GRID = {"origin": (-12.0, -5.0), "resolution": 0.1, "width": 200, "height": 100}


def cell_mass(mu, sigma, lo, hi):
    """The mass of a normal distribution over [lo, hi], from math.erf."""
    phi = lambda x: 0.5 * (1.0 + math.erf((x - mu) / (sigma * math.sqrt(2.0))))
    return phi(hi) - phi(lo)


def test_a_constant_velocity_path_is_a_person_sized_normal_on_the_cells():
    m = cliff_lhmp.Map.demo()
    p = m.predict([WALK], k=1, dt=0.4, horizon=4.0, method="cvm")
    occ = p.occupancy(GRID, [0.4, 2.0])
    assert occ.shape == (2, 100, 200) and occ.dtype == np.float32
    # every sample is one point: the kernel is the person's 0.3 m
    x, y = p.positions[0, 0, 4]  # the position at 2 s
    for row, col in [(55, 115), (54, 118), (50, 110), (58, 120)]:
        x0 = -12.0 + col * 0.1
        y0 = -5.0 + row * 0.1
        want = cell_mass(x, 0.3, x0, x0 + 0.1) * cell_mass(y, 0.3, y0, y0 + 0.1)
        assert abs(occ[1, row, col] - want) < 2e-5, (row, col)
    # one person wholly on the grid
    assert abs(occ[1].sum() - 0.9973**2) < 3e-3
    # a grid as a tuple gives the same
    same = p.occupancy((-12.0, -5.0, 0.1, 200, 100), [0.4, 2.0])
    np.testing.assert_array_equal(occ, same)


def test_a_window_holds_at_least_each_time_within_it():
    m = cliff_lhmp.Map.demo()
    p = m.predict([WALK], k=20, dt=0.4, horizon=8.0, seed=3)
    times = [0.4 * j for j in range(5, 11)]
    layers = p.occupancy(GRID, times)
    window = p.occupancy_window(GRID, 2.0, 4.0)
    assert window.shape == (100, 200)
    # per sample the largest mass over the window's times, averaged: at least the mean
    # over the samples at any one of those times
    assert (window + 1e-6 >= layers.max(axis=0)).all()
    assert window.sum() > layers[0].sum() * 1.5  # the person moves on: a band


def test_a_plan_along_the_path_meets_the_person_and_one_elsewhere_does_not():
    m = cliff_lhmp.Map.demo()
    p = m.predict([WALK], k=1, dt=0.4, horizon=4.0, method="cvm")
    path = p.positions[0, 0]
    along = [(float(x), float(y), 0.4 * (j + 1)) for j, (x, y) in enumerate(path)]
    assert p.path_meets(along, robot_radius=0.3).tolist() == [1.0]
    later = [(x, y, t + 2.0) for x, y, t in along if t + 2.0 <= 4.0]
    assert p.path_meets(later, robot_radius=0.3).tolist() == [0.0]


def test_bad_arguments_are_named():
    m = cliff_lhmp.Map.demo()
    p = m.predict([WALK], k=4, dt=0.4, horizon=2.0)
    with pytest.raises(ValueError, match="grid"):
        p.occupancy({"origin": (0.0, 0.0), "resolution": 0.0, "width": 10, "height": 10}, [0.4])
    with pytest.raises(ValueError, match="grid"):
        p.occupancy({"origin": (0.0, 0.0)}, [0.4])
    with pytest.raises(ValueError, match="time 1"):
        p.occupancy(GRID, [0.4, 9.0])
    with pytest.raises(ValueError, match="stopped"):
        p.occupancy(GRID, [0.4], stopped="vanish")
    with pytest.raises(ValueError, match="plan point 1"):
        p.path_meets([(0.0, 0.0, 1.0), (0.0, 0.0, 0.5)], robot_radius=0.3)
