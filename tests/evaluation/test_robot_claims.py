"""The paper's claims (section V) over 50 randomized seeds per planner x variant
(marl_social.evaluation.run.randomized_overrides: pedestrian timing and speed, the human's lead, speed and
rationality). Episodes are computed once, on two processes.

Closed loop with a learned model: the social planner also runs with theta_hat learned by
inverse optimal control (agents/irl/laplace.py) from 100 near-rational demonstrations of drivers with
the simulated humans' true weights, and must keep the same claims."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.evaluation.reproduce import run_episodes

pytestmark = pytest.mark.slow  # 50-seed claims: minutes; `pytest -m "not slow"` skips them

N_SEEDS = 50
CASES = [("social", "crossing"), ("aggressive", "crossing"), ("social", "none"),
         ("oracle", "none"), ("conservative", "none")]
LEARNED_CASES = [("social", "crossing"), ("social", "none")]


@pytest.fixture(scope="module")
def learned_model(tmp_path_factory):
    """theta.json fitted to near-rational demonstrations of the humans' true weights."""
    from marl_social.agents.irl.laplace import cosine_similarity, fit_theta
    from marl_social.agents.irl.synthetic import near_rational_demonstrations

    from marl_social.sim.costs import CostWeights

    truth = CostWeights().as_array()
    result = fit_theta(near_rational_demonstrations(10.0 * truth, 100, seed=11))
    assert cosine_similarity(result.theta, truth) >= 0.95
    return result.save(tmp_path_factory.mktemp("irl") / "theta.json")


@pytest.fixture(scope="module")
def runs(learned_model) -> dict:
    learned = {"robot_theta_hat": str(learned_model)}
    jobs = [(p, v, s) for p, v in CASES for s in range(N_SEEDS)]
    jobs += [(p, v, s, learned) for p, v in LEARNED_CASES for s in range(N_SEEDS)]
    # the robot passes the crosswalk within 8 s without a pedestrian: 10 s episodes suffice
    horizon = {"crossing": 150, "none": 100}
    out = {case: [] for case in CASES + [c + ("learned",) for c in LEARNED_CASES]}
    for variant, max_cycles in horizon.items():
        mine = [job for job in jobs if job[1] == variant]
        results = run_episodes(mine, workers=2, max_cycles=max_cycles)
        for job, (planner, _v, _seed, metrics, error) in zip(mine, results):
            assert error is None, error
            out[(planner, variant) + (("learned",) if len(job) > 3 else ())].append(metrics)
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


def test_social_planner_with_the_learned_model_keeps_the_claims(runs):
    crossing = runs[("social", "crossing", "learned")]
    assert len(crossing) == N_SEEDS
    assert _rate(runs, ("social", "crossing", "learned"), "robot_collision") == 0.0
    assert _rate(runs, ("social", "crossing", "learned"), "yielded") == 1.0
    social = np.array([m["time_to_pass_s"] for m in runs[("social", "none", "learned")]])
    oracle = np.array([m["time_to_pass_s"] for m in runs[("oracle", "none")]])
    assert np.all(np.isfinite(social))
    assert np.mean(social) <= 1.10 * np.mean(oracle)
