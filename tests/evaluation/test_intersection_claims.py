"""The robot's claims at the T-intersection (paper Fig. 1 b) over 50 randomized seeds.

The randomization is run.RANDOMIZATIONS["t_intersection"] (reproduce_intersection.
randomized_overrides): V3's speed 9-14 m/s, its start 30-45 m ("near") or 110-160 m ("far")
west of the stem, one to three left-turners starting 6-20 m before their turn at 3-8 m/s, every
human's rationality beta 2-30, the gap between the parked cars 0.5-2 m. Episodes are computed
once per module, on two processes.

The claims: with no hidden car the social robot is about as fast as the oracle and much faster
than the conservative robot (which waits for every car it cannot rule out); with V3 near, the
social robot, like the oracle, never collides and never forces V3 to brake hard, while the
aggressive robot (what it cannot see is absent) does in most seeds; and a left-turner that warns
of V3 (its speed departs 1 m/s from the same seed's without V3, evaluation/counterfactual.py)
tells the social robot V3 is there before the robot sees it.

Seeds: MARL_CLAIM_SEEDS (default 50) seeds from MARL_CLAIM_SEED0 (default 0), e.g.
MARL_CLAIM_SEED0=50 runs seeds 50-99 (claims are judged on seeds the code was not tuned on).
The social robot holds short of the lane while a left-turner is still to tell (agents/robot/
sight_hold.py, the scenario knob robot_sight_hold, on by default); MARL_CLAIM_SIGHT_HOLD=0 runs
every robot without it (then the social robot forced V3 to brake hard in 4 of the 50 `near`
seeds 0-49: 8, 23, 34, 35).
"""

from __future__ import annotations

import multiprocessing as mp
import os

import numpy as np
import pytest

from marl_social.evaluation.reproduce_intersection import add_held_back, claim_episode
from tests.helpers import claim_seeds

pytestmark = [pytest.mark.slow, pytest.mark.long]  # 300 episodes: ~11 min of CPU (19 min on 2
# busy cores), outside CI; run with `python -m pytest -m long` (MARL_CLAIM_SEEDS=N: quicker)

SEEDS = claim_seeds()  # MARL_CLAIM_SEEDS, MARL_CLAIM_SEED0 (tests/helpers.claim_seeds)
N_SEEDS = len(SEEDS)
EXTRA = ({"robot_sight_hold": False} if os.environ.get("MARL_CLAIM_SIGHT_HOLD", "1") == "0"
         else {})
CASES = [("social", "none"), ("oracle", "none"), ("conservative", "none"),
         ("social", "near"), ("oracle", "near"), ("aggressive", "near")]
# the robot has cleared the junction within 10 s when nothing comes; with V3 near it goes
# after V3 has passed (V3 reaches the junction within 5 s)
HORIZON = {"none": 120, "near": 150}
HARD_BRAKE_MPS2 = 3.0  # braking forced on V3 beyond this is hard [m/s^2]
BELIEF_HIGH = 0.9  # the belief in a hidden car counts as high above this
WARNED_CASE = ("social", "near")  # its seeds also run without V3: the left-turners' warning
LEAD_S = 0.5  # a left-turner warned at least this long before the robot sees V3 [s]


@pytest.fixture(scope="module")
def runs() -> dict:
    jobs = [(p, v, s, HORIZON[v], EXTRA, (p, v) == WARNED_CASE) for p, v in CASES
            for s in SEEDS]
    with mp.get_context("spawn").Pool(2) as pool:
        results = pool.map(claim_episode, jobs, chunksize=4)
    add_held_back(results)  # pairs each near seed with the same planner and seed without V3
    out = {case: [] for case in CASES}
    for planner, variant, _seed, summary, error in results:
        assert error is None, error
        out[(planner, variant)].append(summary)
    for case, summaries in out.items():  # the measured numbers, shown with `pytest -rA`
        t = np.array([m["time_to_pass_s"] for m in summaries])
        passed = t[~np.isnan(t)]  # the conservative robot may never pass: its mean is nan
        print(case, f"time to pass {passed.mean() if len(passed) else np.nan:.2f} s "
              f"({np.isnan(t).sum()} never),",
              f"collisions {sum(m['robot_collision'] for m in summaries)},",
              f"forced braking max {max(m['others_max_decel_mps2'] for m in summaries):.2f}")
    return out


def _values(runs, case, key) -> np.ndarray:
    return np.array([m[key] for m in runs[case]], dtype=np.float64)


def _time_to_pass(runs, case) -> np.ndarray:
    """(N_SEEDS,) time to pass [s]; a robot that never passed counts as the episode's length."""
    t = _values(runs, case, "time_to_pass_s")
    return np.where(np.isfinite(t), t, HORIZON[case[1]] * 0.1)


def test_social_is_nearly_as_fast_as_the_oracle_without_hidden_car(runs):
    """Within 10 % of the oracle's mean time to clear the junction."""
    social = _values(runs, ("social", "none"), "time_to_pass_s")
    oracle = _values(runs, ("oracle", "none"), "time_to_pass_s")
    assert np.all(np.isfinite(social)) and np.all(np.isfinite(oracle))
    assert np.mean(social) <= 1.10 * np.mean(oracle), (np.mean(social), np.mean(oracle))


def test_social_is_much_faster_than_the_conservative_robot_without_hidden_car(runs):
    """At least 25 % sooner than the conservative robot on average.

    Measured: the conservative robot never passes (50 of 50 seeds; counted as the episode's
    length). From the stop line its sensor sees 8-11 m of the eastbound lane past the parked
    cars, 12-18 m with its front at the lane's edge, while a car at the speed limit it cannot
    rule out may reach the zone from 55 m (the hidden-vehicle bins) and clearing the zone from
    a standstill takes it about 6 s: the three most upstream progress bins (16-50 m west of
    the stem) stay unseen, at their prior, and so are never ruled out.
    """
    social = _time_to_pass(runs, ("social", "none"))
    conservative = _time_to_pass(runs, ("conservative", "none"))
    assert np.mean(social) <= 0.75 * np.mean(conservative), (np.mean(social),
                                                             np.mean(conservative))


@pytest.mark.parametrize("planner", ["social", "oracle"])
def test_robot_gives_way_to_a_near_hidden_car(runs, planner):
    """Never a collision, never forcing V3 (or a left-turner) to brake harder than 3 m/s^2.

    The social robot only with its sight hold (agents/robot/sight_hold.py; measured 0 forced in
    400 seeds, 0-399): without it it rolls out of its stop line on its prior where no
    left-turner has told it anything yet (the left-turner 15 m from its turn in seed 34, V3
    passing first), V3 sees it rolling (~2 m/s, ~2 m short of the lane) a step before the robot
    sees V3 and, predicting it at constant speed into its lane, brakes at 6-8 m/s^2: 4 of 50
    (0-49: 8, 23, 34, 35; before a merge claim was held short of the zone, 8 of 200 on 0-199,
    3 of 50 on 300-349, 1 on 350-399, 2 on 600-649). Tried before the hold
    (2026-12-01/02): epsilon over a hidden car as a whole (0 of 50, but 7.6-10.4 s against the
    oracle's 6.7 s with no hidden car), creeping while a hidden car weighs >= epsilon (0 forced
    on 0-149, but 17-19 % slower than the oracle), the humans' uncertain view of the robot's
    velocity (no gain).
    """
    case = (planner, "near")
    assert len(runs[case]) == N_SEEDS
    assert _values(runs, case, "robot_collision").sum() == 0
    forced = _values(runs, case, "others_max_decel_mps2")
    assert np.all(forced <= HARD_BRAKE_MPS2), np.sort(forced)


def test_aggressive_robot_pulls_out_in_front_of_a_near_hidden_car(runs):
    """What it does not see is absent: it collides or forces hard braking in most seeds.

    It stops at the stop sign, rolls out and sees V3 past the parked cars about a second before
    V3 reaches the junction: V3, seeing it roll towards its lane, brakes hard (measured
    2026-12-03: 34, 35, 33, 34, 29, 28, 30 and 32 of 50 on seeds 0-49 ... 350-399, up to 8
    m/s^2, no collision). Which seeds it forces is decided by when it first sees V3: V3
    starting 30-45 m west at 9-14 m/s is in view early in 36-44 % of the near seeds, and
    before a merge claim was held short of the zone (agents/robot/right_of_way.py) the robot,
    held a car length further back behind a car it had seen, then waited like any robot: 19
    of 50 on 200-249 and 22-24 on 250-399 and 600-649 (2026-12-01/03).
    """
    case = ("aggressive", "near")
    bad = (_values(runs, case, "robot_collision").astype(bool)
           | (_values(runs, case, "others_max_decel_mps2") > HARD_BRAKE_MPS2))
    assert np.mean(bad) > 0.5, np.mean(bad)


def test_a_warning_left_turner_tells_the_social_robot_of_the_hidden_car(runs):
    """In >= 90 % of the near seeds where a left-turner warns of V3 at least LEAD_S before the
    robot first sees it, the robot's belief in a hidden car exceeds 0.9 before that sight.

    Warns (evaluation/counterfactual.py): its speed departs >= 1 m/s from its speed in the
    same seed without V3 (what it does because of V3, not its curve speed).

    Measured 35 of 37 (95 %) on seeds 0-49 and 31 of 36 (86 %, below the claim) on 50-99:
    the misses 30 and 38 are confident 0.1 s after the sight, 63, 69, 80, 93 and 95 later.
    Counted before as "human_0 waited for V3" (it let V3 pass, slower than 3.5 m/s and 0.3
    m/s slower than without V3 at a step before V3 left the crossing; no lead asked), it was
    36 of 36 on 0-49, 94 % of 33 on 50-99, 96 % of 28 on 100-149, 91 % of 35 on 150-199 and
    94 % of 33 on 250-299 (reproduce_intersection.left_turner_held_back, still in its table).
    """
    warned = [m for m in runs[WARNED_CASE] if m["warning_lead_s"] >= LEAD_S]
    assert len(warned) >= 10
    early = [m["belief_09_s"] < np.nan_to_num(m["robot_first_sees_v3_s"], nan=np.inf)
             for m in warned]
    assert np.mean(early) >= 0.9, np.mean(early)
