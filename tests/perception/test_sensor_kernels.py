"""perception/sensor_kernels.py gives, bit for bit, what the numpy measurement it replaced gave."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.perception.sensors import measure


def _reference(visible, xy, heading, speed, pos_noise_m, vel_noise_mps, heading_noise_rad, rng):
    """perception.sensors.measure before the kernels."""
    obs, tgt = np.nonzero(visible)
    d = xy[tgt] - xy[obs]
    dist = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1])
    order = np.lexsort((tgt, dist, obs))
    obs, tgt, dist = obs[order], tgt[order], dist[order]
    noise = rng.standard_normal((len(obs), 5))
    true_vel = np.empty((len(speed), 2))
    true_vel[:, 0] = speed * np.cos(heading)
    true_vel[:, 1] = speed * np.sin(heading)
    m_xy = xy[tgt] + noise[:, 0:2] * pos_noise_m[obs, None]
    m_vel = true_vel[tgt] + noise[:, 2:4] * vel_noise_mps[obs, None]
    m_heading = heading[tgt] + noise[:, 4] * heading_noise_rad[obs]
    return obs, tgt, m_xy, m_vel, m_heading, dist


def _inputs(rng, n, grid):
    state = np.zeros((n, 5))  # the world's state table: its columns are strided views
    # on a grid, many targets sit at the same distance from an observer (ties: by target)
    state[:, :2] = (rng.integers(-3, 4, (n, 2)).astype(float) if grid
                    else rng.uniform(-50.0, 50.0, (n, 2)))
    state[:, 2] = rng.uniform(-7.0, 7.0, n)
    state[:, 3] = rng.uniform(0.0, 20.0, n)
    visible = rng.random((n, n)) < 0.7
    return (visible, state[:, :2], state[:, 2], state[:, 3], rng.uniform(0.0, 0.5, n),
            rng.uniform(0.0, 0.5, n), rng.uniform(0.0, 0.1, n))


@pytest.mark.parametrize("seed", range(60))
def test_measurements_are_numpys_bits(seed):
    rng = np.random.default_rng(seed)
    args = _inputs(rng, int(rng.integers(1, 12)), grid=seed % 2 == 0)
    expected = _reference(*args, np.random.default_rng(seed))
    got = measure(*args, np.random.default_rng(seed))
    for e, g in zip(expected, (got.observer, got.target, got.xy, got.velocity, got.heading,
                               got.distance_m)):
        assert e.dtype == g.dtype and e.shape == g.shape
        assert e.tobytes() == g.tobytes()


def test_a_nan_distance_sorts_last_as_in_numpy():
    xy = np.array([[0.0, 0.0], [np.nan, 1.0], [3.0, 0.0], [1.0, 0.0]])
    visible = np.zeros((4, 4), bool)
    visible[0, 1:] = True
    args = (visible, xy, np.zeros(4), np.ones(4), np.full(4, 0.1), np.full(4, 0.1),
            np.full(4, 0.01))
    expected = _reference(*args, np.random.default_rng(0))
    got = measure(*args, np.random.default_rng(0))
    assert got.target.tolist() == expected[1].tolist() == [3, 2, 1]
