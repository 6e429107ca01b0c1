"""The paper's claims (section V) over 50 randomized seeds per planner x variant
(marl_social.run.randomized_overrides: pedestrian timing and speed, the human's lead, speed and
rationality). Episodes are computed once, on two processes."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.reproduce import run_episodes

N_SEEDS = 50
CASES = [("social", "crossing"), ("aggressive", "crossing"), ("social", "none"),
         ("oracle", "none"), ("conservative", "none")]


@pytest.fixture(scope="module")
def runs() -> dict:
    results = run_episodes([(p, v, s) for p, v in CASES for s in range(N_SEEDS)], workers=2,
                           max_cycles=150)
    out = {case: [] for case in CASES}
    for planner, variant, _seed, metrics, error in results:
        assert error is None, error
        out[(planner, variant)].append(metrics)
    return out


def _rate(runs, case, key) -> float:
    return float(np.mean([m[key] for m in runs[case]]))


def test_social_planner_never_collides_and_always_yields(runs):
    case = ("social", "crossing")
    assert len(runs[case]) == N_SEEDS
    assert _rate(runs, case, "robot_collision") == 0.0
    assert _rate(runs, case, "yielded") == 1.0


def test_aggressive_planner_collides_or_brakes_hard_in_most_seeds(runs):
    bad = [m["robot_collision"] or m["max_decel_mps2"] > 5.0
           for m in runs[("aggressive", "crossing")]]
    assert np.mean(bad) > 0.5


def test_social_is_as_fast_as_the_oracle_without_pedestrian(runs):
    social = np.array([m["time_to_pass_s"] for m in runs[("social", "none")]])
    oracle = np.array([m["time_to_pass_s"] for m in runs[("oracle", "none")]])
    conservative = np.array([m["time_to_pass_s"] for m in runs[("conservative", "none")]])
    assert np.all(np.isfinite(social)) and np.all(np.isfinite(oracle))
    assert np.mean(social) <= 1.10 * np.mean(oracle)
    conservative = np.where(np.isfinite(conservative), conservative, np.inf)
    assert np.mean(conservative) >= 1.20 * np.mean(oracle)


def test_belief_rises_before_the_robot_sees_the_pedestrian(runs):
    confident = [m["belief_confident_before_seen"] for m in runs[("social", "crossing")]]
    assert np.mean(confident) >= 0.9


def test_belief_stays_low_as_the_robot_passes_without_pedestrian(runs):
    low = [m["p_pedestrian_at_crosswalk"] < 0.1 for m in runs[("social", "none")]]
    assert np.mean(low) >= 0.9
