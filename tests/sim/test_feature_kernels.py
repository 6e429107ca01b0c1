"""sim/feature_kernels.py gives, bit for bit, the numpy pairwise features it replaced.

The numpy reference: tests/reference/pairwise_features.py. Any number of agents: rows longer
than numpy's pairwise block (128) sum in halves, as np.sum does.
"""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.sim.costs import AgentFootprints, AgentMotion, pairwise_step_features
from marl_social.sim.footprint import circle_layout, place_along
from marl_social.sim.road_map import Crosswalk
from tests.reference.pairwise_features import pairwise_step_features as numpy_features


def _scene(rng, n, spread_m):
    is_ped = rng.random(n) < 0.4
    length = np.where(is_ped, 0.6, rng.uniform(3.5, 5.5, n))
    width = np.where(is_ped, 0.6, rng.uniform(1.6, 2.1, n))
    state = np.zeros((n, 4))  # the world's state table: speeds are a column of it
    state[:, :2] = rng.uniform(-spread_m, spread_m, (n, 2)) + [50.0, 0.0]
    state[:, 2] = rng.uniform(-np.pi, np.pi, n)
    state[:, 3] = rng.uniform(0, 15, n)
    xy = state[:, :2]
    along, circle_r = circle_layout(length, width, is_ped)
    active = rng.random(n) < 0.8
    motion = AgentMotion(rng.normal(0, 1, n), state[:, 3],
                         rng.uniform(5, 15, n) if rng.random() < 0.7 else 8.0,
                         rng.normal(0, 2, n), rng.normal(0, 2, n))
    bodies = AgentFootprints(xy, 0.5 * np.hypot(length, width), is_ped,
                         place_along(xy, state[:, 2], along), circle_r)
    crosswalks = (Crosswalk(np.array([50.0, 0.0]), np.pi / 2, 8.0, 4.0),
                  Crosswalk(np.array([45.0, 3.0]), 0.3, 6.0, 3.0))[:int(rng.integers(0, 3))]
    return {"motion": motion, "bodies": bodies,
            "other_mask": active[None, :] & ~np.eye(n, dtype=bool), "crosswalks": crosswalks,
            "kinds_differ": None}


@pytest.mark.parametrize("seed", range(40))
def test_the_kernels_give_the_numpy_features(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.choice([1, 2, 3, 7, 8, 9, 15, 16, 17, 31, 64, 100, 128, 129, 140]))
    args = _scene(rng, n, spread_m=float(rng.choice([2.0, 20.0, 200.0])))
    expected = numpy_features(**args)
    got = pairwise_step_features(**args)
    assert got.shape == expected.shape and got.dtype == expected.dtype
    assert got.tobytes() == expected.tobytes()


def test_a_nan_position_gives_numpys_nans():
    rng = np.random.default_rng(1)
    args = _scene(rng, 5, 10.0)
    circles = args["bodies"].circles.copy()
    circles[2, 1, 0] = np.nan
    args["bodies"] = args["bodies"]._replace(circles=circles)
    with np.errstate(invalid="ignore"):
        expected = numpy_features(**args)
        got = pairwise_step_features(**args)
    assert np.array_equal(got, expected, equal_nan=True)
    assert np.array_equal(np.signbit(got), np.signbit(expected))


@pytest.mark.parametrize("n", [127, 128, 129, 136, 255, 256, 257, 300, 520])
def test_more_agents_than_one_pairwise_block(n):
    """Rows of more than 128 agents (np.sum's recursive halving): still numpy's bits."""
    rng = np.random.default_rng(n)
    args = _scene(rng, n, spread_m=20.0)
    args["crosswalks"] = (Crosswalk(np.array([50.0, 0.0]), np.pi / 2, 8.0, 4.0),)
    expected = numpy_features(**args)
    got = pairwise_step_features(**args)
    assert got.tobytes() == expected.tobytes()
