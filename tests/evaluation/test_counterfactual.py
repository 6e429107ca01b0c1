"""The counterfactual warning (evaluation/counterfactual.py, run_episode(counterfactual=True))."""

from __future__ import annotations

import math

import numpy as np
import pytest

from marl_social.evaluation.counterfactual import WARNING_SPEED_MPS, warning_lead_s
from marl_social.evaluation.run import randomized_overrides, run_episode
from marl_social.scenarios import SCENARIOS, make_scenario

# the example: a near-rational human slows for the pedestrian from 0.8 s, which its
# speed when the pedestrian started (0.17 s) hardly shows
SEED_217 = {"pedestrian_speed_mps": 1.56, "pedestrian_start_delay_s": 0.17,
            "human_lead_m": 20.4, "human_speed_mps": 10.14, "human_beta": 26.83}


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_the_hidden_agents_come_last_so_the_others_keep_their_policy_seeds(name):
    """record_episode seeds agent i's policy with seed + i: removing the last agents shifts none."""
    for variant in SCENARIOS[name].variants:
        scenario = make_scenario(name, **variant)
        hidden = scenario.hidden_agent()
        if hidden is None:
            continue
        agents = [a.name for a in scenario.build(np.random.default_rng(0)).agents]
        without = [a.name for a in make_scenario(name, **{**variant, **hidden.absent})
                   .build(np.random.default_rng(0)).agents]
        assert agents[:len(agents) - len(hidden.names)] == without[:len(agents)
                                                                  - len(hidden.names)]
        assert tuple(agents[len(agents) - len(hidden.names):]) == hidden.names
        assert not set(hidden.names) & set(without)


def test_a_scene_without_its_hidden_agent_hides_nothing():
    assert make_scenario("occluded_crosswalk", pedestrian="none").hidden_agent() is None
    assert make_scenario("t_intersection", hidden_vehicle="none").hidden_agent() is None
    assert make_scenario("long_road").hidden_agent() is None


def test_the_lead_counts_only_warnings_before_the_robot_sees_the_hidden_agent():
    assert warning_lead_s({"human_0": 0.8, "human_1": 1.2}, 1.8) == pytest.approx(1.0)
    assert warning_lead_s({"human_0": 2.5}, 1.8) == 0.0
    assert warning_lead_s({"human_0": math.nan}, 1.8) == 0.0
    assert math.isnan(warning_lead_s({"human_0": 0.8}, math.nan))
    assert warning_lead_s({"human_0": 0.8}, 1.3) == 0.5  # not 0.4999...: rounded to 1e-9 s


def test_the_human_warns_where_it_departs_from_the_same_seed_without_the_pedestrian():
    """The issue's seed 217: the human drives >= 1 m/s slower than without the pedestrian from
    0.8 s, 1 s before the robot first sees the pedestrian."""
    res = run_episode("occluded_crosswalk", seed=217, robot_planner="social",
                      pedestrian="crossing", counterfactual=True, **SEED_217)
    without = run_episode("occluded_crosswalk", seed=217, robot_planner="social",
                          pedestrian="none", max_cycles=len(res.trace.times_s) - 1, **SEED_217)
    warned = res.warning.human_warned_s["human_0"]
    assert warned == pytest.approx(0.8)
    h = res.trace.index("human_0")
    k = round(warned / 0.1)
    gap = without.trace.states[: k + 1, h, 3] - res.trace.states[: k + 1, h, 3]
    assert gap[-1] >= WARNING_SPEED_MPS and np.all(np.abs(gap[:-1]) < WARNING_SPEED_MPS)
    sight = res.metrics["robot_first_sees_pedestrian_s"]
    assert res.warning.robot_first_sees_s == sight
    assert res.metrics["warning_lead_s"] == pytest.approx(sight - warned)
    assert res.metrics["human_warned_s_human_0"] == warned
    assert res.warning.hidden.belief in res.trace.extras


def test_without_the_counterfactual_the_metrics_are_unchanged():
    plain = run_episode("occluded_crosswalk", seed=3, max_cycles=20)
    asked = run_episode("occluded_crosswalk", seed=3, max_cycles=20, counterfactual=True)
    assert plain.warning is None
    assert set(asked.metrics) - set(plain.metrics) == {
        "warning_lead_s", "first_warned_s", "robot_first_sees_hidden_s", "human_warned_s_human_0"}
    assert {k: plain.metrics[k] for k in plain.metrics} == pytest.approx(
        {k: asked.metrics[k] for k in plain.metrics}, nan_ok=True)
    assert np.array_equal(plain.trace.states, asked.trace.states)


@pytest.mark.parametrize("seed", [20000, 20001, 20003])
def test_the_left_turners_draw_alike_with_and_without_a_far_hidden_car(seed):
    """Until anyone sees V3 (far), the left-turners drive exactly as without it.

    Their choices draw from their own generators (seeded by their index); the sensor noise is
    one stream, which V3's own observations shift: measured 28 of 30 fresh seeds of each of
    the crosswalk (before the pedestrian walks) and this scene identical, the others one
    choice apart (0.1-0.2 m/s).
    """
    overrides = {**randomized_overrides(seed, "t_intersection"), "hidden_vehicle": "far"}
    res = run_episode("t_intersection", seed=seed, max_cycles=40, **overrides)
    without = run_episode("t_intersection", seed=seed, max_cycles=40,
                          **{**overrides, "hidden_vehicle": "none"})
    trace = res.trace
    v3 = trace.index(f"human_{overrides['n_humans']}")
    seen = np.delete(trace.visible[:, :, v3], v3, axis=1).any(axis=1)
    cut = int(np.argmax(seen)) if seen.any() else len(seen)
    assert cut > 10
    for k in range(overrides["n_humans"]):
        i = trace.index(f"human_{k}")
        assert np.array_equal(trace.states[:cut, i], without.trace.states[:cut, i])


def test_at_the_signal_the_counterfactual_is_the_other_phase():
    """The robot sees the cross cars from the start: the hidden thing is their phase; the
    left-turners, going on their arrow, depart from the same seed on cross green."""
    res = run_episode("signalized_intersection", seed=3, phase="protected_left",
                      max_cycles=40, counterfactual=True)
    assert res.warning.hidden.absent == {"phase": "cross_green"}
    assert res.warning.hidden.names == ()
    assert math.isnan(res.warning.robot_first_sees_s)
    assert math.isnan(res.warning.warning_lead_s)
    assert np.isfinite(res.warning.human_warned_s["human_0"])
