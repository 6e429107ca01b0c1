"""Hidden-agent hypotheses of a map and their motion model (perception/belief/hypotheses.py)."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.perception.belief import (
    BeliefConfig,
    crosswalk_hypotheses,
    motion_transition,
    stationary_distribution,
)
from tests.perception.belief.episodes import CROSSWALK_X_M, paper_env


def test_crosswalk_hypotheses_of_the_paper_map():
    env = paper_env()
    hyps = crosswalk_hypotheses(env.road_map, walk_speeds_mps=1.3, curb_offset_m=1.0)
    assert [h.name for h in hyps] == ["none", "crossing_right", "crossing_left"]
    assert not hyps[0].present and hyps[1].present and hyps[2].present
    right, left = hyps[1], hyps[2]
    np.testing.assert_allclose(right.start_xy, [CROSSWALK_X_M, -4.5])  # curb y = -3.5
    np.testing.assert_allclose(right.walk_dir, [0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(left.start_xy, [CROSSWALK_X_M, 4.5])
    xy = right.predict_xy(np.array([0.0, 1.0, 100.0]))
    np.testing.assert_allclose(xy, [[60.0, -4.5], [60.0, -3.2], [60.0, 4.5]], atol=1e-12)
    region = right.region()
    assert region.shape[1] == 2 and len(region) >= 9
    assert region[:, 1].min() >= -5.0 - 1e-9 and region[:, 1].max() <= -2.5 + 1e-9
    assert np.abs(region[:, 0] - CROSSWALK_X_M).max() <= 2.0
    with pytest.raises(ValueError):
        hyps[0].predict_xy(np.array([0.0]))


def _binned():
    cfg = BeliefConfig()
    return crosswalk_hypotheses(paper_env().road_map, cfg.walk_speeds_mps, cfg.curb_offset_m,
                                cfg.progress_step_m), cfg


def test_hypotheses_include_pedestrians_already_on_the_road():
    hyps, cfg = _binned()
    right = [h for h in hyps if h.path == "crossing_right"]
    assert {h.kind for h in right} == {"pedestrian"}
    assert sorted({h.progress_m for h in right}) == [0.0, 2.5, 5.0]
    assert sorted({h.walk_speed_mps for h in right}) == sorted(cfg.walk_speeds_mps)
    on_road = next(h for h in right if h.progress_bin == 2 and h.speed_bin == 0)
    np.testing.assert_allclose(on_road.predict_xy(np.array([0.0, 1.0])),
                               [[CROSSWALK_X_M, 0.5], [CROSSWALK_X_M, 0.5 + 0.9]], atol=1e-12)
    # its region is where it is now, on the road, not at the curb
    assert on_road.region()[:, 1].min() >= 0.0 - 1e-9 and on_road.region()[:, 1].max() <= 3.0


def test_hypotheses_progress_along_their_paths():
    """The motion model: mass put on "steps off the right curb now at 1.6 m/s" moves along the
    crossing at 1.6 m/s on average, and leaves for "none" once it has crossed; "none" feeds
    only the curb entries."""
    hyps, _ = _binned()
    dt = 0.1
    mat = motion_transition(hyps, dt, hazard_per_s=0.0)
    np.testing.assert_allclose(mat.sum(axis=0), 1.0)
    start = next(i for i, h in enumerate(hyps)
             if h.path == "crossing_right" and h.progress_bin == 0 and h.speed_bin == 1)
    progress = np.array([h.progress_m for h in hyps])
    p = np.zeros(len(hyps))
    p[start] = 1.0
    for step in range(1, 31):
        p = mat @ p
        present = p[1:].sum()
        mean = (p[1:] @ progress[1:]) / present
        assert {hyps[i].path for i in np.flatnonzero(p[1:] > 1e-12) + 1} == {"crossing_right"}
        assert {hyps[i].speed_bin for i in np.flatnonzero(p[1:] > 1e-12) + 1} == {1}
        if step in (5, 10):  # before much mass reaches the last bin
            assert abs(mean - 1.6 * dt * step) < 0.3, (step, mean)
    for _ in range(200):
        p = mat @ p
    assert p[0] > 0.99  # it has crossed
    with_hazard = motion_transition(hyps, dt, hazard_per_s=0.05)
    born = with_hazard[:, 0]
    assert born[0] == 1.0 - 0.005 and all(hyps[i].progress_bin == 0
                                          for i in np.flatnonzero(born[1:]) + 1)
    longrun = stationary_distribution(with_hazard)
    assert 0.0 < longrun[1:].sum() < 0.5



def _power_iteration(transition: np.ndarray) -> np.ndarray:
    p = np.full(len(transition), 1.0 / len(transition))
    power = np.linalg.matrix_power(transition, 2)
    for _ in range(1000):
        p = power @ p
    return p / p.sum()


def test_the_kept_long_run_distribution_is_the_power_iteration_and_a_fresh_array():
    """stationary_distribution keeps its result per transition: a repeated call gives the bits
    of the power iteration itself, as a new array (the belief's prior changes the one it
    gets), and another transition gets its own."""
    env = paper_env()
    hyps = crosswalk_hypotheses(env.road_map, walk_speeds_mps=1.3, curb_offset_m=1.0,
                                progress_step_m=0.5)
    transition = motion_transition(hyps, 0.1, hazard_per_s=0.05)
    first = stationary_distribution(transition)
    first[:] = -1.0
    again = stationary_distribution(transition.copy())
    np.testing.assert_array_equal(again, _power_iteration(transition))
    other_transition = motion_transition(hyps, 0.1, hazard_per_s=0.5)
    other = stationary_distribution(other_transition)
    np.testing.assert_array_equal(other, _power_iteration(other_transition))
    assert not np.array_equal(other, again)
