"""The robot's claims at the signalized intersection (paper Fig. 1 c) over 50 randomized seeds.

The randomization is run.RANDOMIZATIONS["signalized_intersection"] (reproduce_signal.
randomized_overrides): one or two cross cars starting 30-60 m before their line at 9-14 m/s,
12-25 m apart; one to three left-turners queued 2-8 m behind their line; every human's
rationality beta 2-30; 0-2 s already spent in the phase; the robot 0-3 m behind its line.
Episodes are computed once per module, on two processes.

The claims: on the protected left the social robot, reading the left-turners' start as "the
cross traffic has red", turns at least 2 s sooner than the conservative robot (which waits
for the cross traffic to stop or pass) and within 15 % of the oracle (which knows the phase),
without collision; with the cross traffic on green the social robot never collides and never
forces a cross car to brake harder than 3 m/s^2, while the aggressive robot (it assumes the
favourable phase) collides or forces hard braking in most seeds; where a human warns it of the
protected left (its speed departs 1 m/s from the same seed's on cross green,
evaluation/counterfactual.py: a left-turner starts, a cross car slows for its red) the social
robot's belief in that phase is confident before it pulls out.
"""

from __future__ import annotations

import multiprocessing as mp

import numpy as np
import pytest

from marl_social.evaluation.reproduce_signal import FORCED_BRAKE_MPS2, MAX_CYCLES, claim_episode
from tests.helpers import claim_seeds

pytestmark = [pytest.mark.slow, pytest.mark.long]  # 50 seeds x 5 cases: long, outside CI;
# run with `python -m pytest -m long` (MARL_CLAIM_SEEDS=N for a quicker look)

SEEDS = claim_seeds()  # MARL_CLAIM_SEEDS, MARL_CLAIM_SEED0 (tests/helpers.claim_seeds)
CASES = [("social", "protected_left"), ("conservative", "protected_left"),
         ("oracle", "protected_left"), ("social", "cross_green"), ("aggressive", "cross_green")]
WARNED_CASE = ("social", "protected_left")  # its seeds also run on cross green: the warning
LEAD_S = 0.5  # a human warned at least this long before the robot pulls out [s]


@pytest.fixture(scope="module")
def runs() -> dict:
    jobs = [(p, v, s, MAX_CYCLES, (p, v) == WARNED_CASE) for p, v in CASES for s in SEEDS]
    with mp.get_context("spawn").Pool(2) as pool:
        results = pool.map(claim_episode, jobs, chunksize=4)
    out = {case: [] for case in CASES}
    for planner, variant, _seed, summary, error in results:
        assert error is None, error
        out[(planner, variant)].append(summary)
    for case, summaries in out.items():  # the measured numbers, shown with `pytest -rA`
        t = [m["turn_s"] for m in summaries]
        print(case, f"turns at {np.nanmean(t):.2f} s ({np.isnan(t).sum()} never),",
              f"collisions {sum(m['collision'] for m in summaries)},",
              f"forced braking max {max(m['others_max_decel_mps2'] for m in summaries):.2f},",
              f"collision or forced braking > {FORCED_BRAKE_MPS2:g} m/s^2 in",
              f"{np.mean([_bad(m) for m in summaries]):.0%}")
    return out


def _bad(summary) -> bool:
    """The robot collided or forced a human to brake harder than FORCED_BRAKE_MPS2."""
    return bool(summary["collision"]) or summary["others_max_decel_mps2"] > FORCED_BRAKE_MPS2


def _turn_s(runs, case) -> np.ndarray:
    """(len(SEEDS),) when the robot's front passes its line [s]; never: the episode's length."""
    t = np.array([m["turn_s"] for m in runs[case]], dtype=np.float64)
    return np.where(np.isfinite(t), t, MAX_CYCLES * 0.1)


def test_social_turns_at_least_2_s_sooner_than_the_conservative_robot(runs):
    social = _turn_s(runs, ("social", "protected_left"))
    conservative = _turn_s(runs, ("conservative", "protected_left"))
    assert np.mean(conservative) - np.mean(social) >= 2.0, (np.mean(social),
                                                            np.mean(conservative))


def test_social_turns_within_15_percent_of_the_oracle(runs):
    social = _turn_s(runs, ("social", "protected_left"))
    oracle = _turn_s(runs, ("oracle", "protected_left"))
    assert np.mean(social) <= 1.15 * np.mean(oracle), (np.mean(social), np.mean(oracle))


def test_social_never_collides(runs):
    for variant in ("protected_left", "cross_green"):
        assert not any(m["collision"] for m in runs[("social", variant)]), variant


def test_social_never_forces_the_cross_traffic_to_brake_hard(runs):
    """Holds on seeds 0-49 and on 350 fresh seeds.

    Measured 2026-12-03 (MARL_CLAIM_SEED0), social on cross_green: 0 forced > 3 m/s^2 on
    0-49 and on 50-199, 400-549 and 600-649 (every claim of this module holds there); in
    three of those (171, 535 and one of 600-649) the cross car brakes at its own -3 m/s^2
    candidate, so the margin is none (forced braking is rounded to 1e-6 m/s^2, metrics/physical.py:
    the effective acceleration, a speed difference over a step, read 3.000000000000007).
    Before the merge's follower model reacted to the robot's lane entry (agents/robot/
    right_of_way.py, RightOfWay.lane_entry_s; it braked 2 s after each plan's start) 14 of
    those 300 were forced at 3-6 m/s^2, the oracle in 10 and the conservative robot in 12 of
    them: the robot turned right on red in front of a cross car 4-5 s away, rounded the corner
    at <= 3.9 m/s, and the car, out of its view once it had turned, braked hard behind it as
    it straightened into the lane.
    """
    worst = max(m["others_max_decel_mps2"] for m in runs[("social", "cross_green")])
    assert worst <= FORCED_BRAKE_MPS2, worst


def test_aggressive_collides_or_forces_hard_braking_in_most_cross_green_seeds(runs):
    """Measured 68 % of seeds 0-49, 76 % of 50-99 (2026-12-03). In the others the first cross car is slow or
    far enough for the robot to turn in front of it unhurried, or already too close to stop
    (more than 8 m/s^2) when the robot is ready: even the aggressive robot then waits for it."""
    bad = [_bad(m) for m in runs[("aggressive", "cross_green")]]
    assert np.mean(bad) > 0.5, np.mean(bad)


def test_a_warning_human_tells_the_social_robot_the_protected_left(runs):
    """Where a human warned >= LEAD_S before the robot pulls out, the robot's belief in the
    protected left exceeds 0.9 before it pulls out in >= 95 % of those seeds.

    A human warns in every protected-left seed (the cross cars slow for their red, the
    left-turners go). Measured 49 of 50 on seeds 0-49 (seed 24: the robot pulls out at 2.5 s
    with its belief below 0.9 all along) and 46 of 50 (92 %, below the claim) on 50-99
    (52, 55, 56, 87).
    """
    warned = [m for m in runs[WARNED_CASE]
              if m["first_warned_s"] <= np.nan_to_num(m["turn_s"], nan=np.inf) - LEAD_S]
    assert len(warned) >= 10
    early = [m["belief_09_s"] < np.nan_to_num(m["turn_s"], nan=np.inf) for m in warned]
    assert np.mean(early) >= 0.95, np.mean(early)
