"""Bad input gets a clear error naming the agent or field; physical limits saturate."""

from __future__ import annotations

import numpy as np
import pytest

import marl_social
from tests.helpers import zero_actions


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_action_names_the_agent(paper_env, bad):
    paper_env.reset(seed=0)
    actions = zero_actions(paper_env)
    actions["human_0"] = np.array([0.0, bad])
    with pytest.raises(ValueError, match="human_0.*NaN or inf"):
        paper_env.step(actions)


@pytest.mark.parametrize("bad", [np.zeros(3), np.zeros((2, 1)), 1.0, np.zeros(0)])
def test_wrong_shape_names_the_agent(paper_env, bad):
    paper_env.reset(seed=0)
    actions = zero_actions(paper_env)
    actions["pedestrian_0"] = bad
    with pytest.raises(ValueError, match=r"pedestrian_0.*shape \(2,\)"):
        paper_env.step(actions)


def test_non_numeric_action(paper_env):
    paper_env.reset(seed=0)
    actions = zero_actions(paper_env)
    actions["robot_0"] = ["fast", "left"]
    with pytest.raises(ValueError, match="robot_0.*not numeric"):
        paper_env.step(actions)


def test_unknown_agent(paper_env):
    paper_env.reset(seed=0)
    actions = zero_actions(paper_env)
    actions["human_7"] = np.zeros(2)
    with pytest.raises(ValueError, match="unknown agent 'human_7'"):
        paper_env.step(actions)


def test_missing_agent(paper_env):
    paper_env.reset(seed=0)
    actions = zero_actions(paper_env)
    del actions["human_0"]
    with pytest.raises(ValueError, match="human_0"):
        paper_env.step(actions)


def test_step_before_reset():
    with pytest.raises(RuntimeError, match="reset"):
        marl_social.parallel_env().step({})


def test_out_of_range_actions_saturate_at_physical_limits(paper_env):
    paper_env.reset(seed=0)
    world = paper_env.world
    v0 = world.state[:, 3].copy()
    actions = {
        "robot_0": np.array([100.0, 0.0]),       # accel_max is 3 m/s^2
        "human_0": np.array([-100.0, 0.0]),      # brake_max is 8 m/s^2
        "pedestrian_0": np.array([30.0, 40.0]),  # 50 m/s command, speed_max is 2 m/s
    }
    paper_env.step(actions)
    assert world.state[0, 3] == pytest.approx(v0[0] + 0.3)
    assert world.state[1, 3] == pytest.approx(v0[1] - 0.8)
    assert world.state[2, 3] == pytest.approx(2.0)
    heading = world.state[2, 2]
    assert heading == pytest.approx(np.arctan2(40.0, 30.0))


def test_steering_saturates_with_lateral_acceleration(paper_env):
    """At 11.5 m/s a full 0.6 rad steer would pull ~30 m/s^2; the G-G limit (6 m/s^2) caps it."""
    paper_env.reset(seed=0)
    world = paper_env.world
    actions = zero_actions(paper_env)
    actions["robot_0"] = np.array([0.0, 5.0])
    paper_env.step(actions)
    v = world.state[0, 3]
    yaw_rate = world.state[0, 2] / 0.1
    assert v * abs(yaw_rate) <= 6.0 + 1e-6
    assert v * abs(yaw_rate) > 5.5


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"pedestrian": "dancing"}, "pedestrian.*crossing"),
        ({"human_lead_m": 1.0}, "human_lead_m"),
        ({"robot_sensor_range_m": -5.0}, "robot_sensor_range_m"),
        ({"pedestrian_speed_mps": "fast"}, "pedestrian_speed_mps.*number"),
        ({"pedestrian_speed_mps": float("nan")}, "NaN"),
        ({"n_slots": 2.5}, "n_slots.*integer"),
        ({"robot_speedd_mps": 3.0}, "unknown scenario parameter.*robot_speedd_mps"),
    ],
)
def test_invalid_scenario_overrides(overrides, message):
    with pytest.raises(ValueError, match=message):
        marl_social.parallel_env(**overrides)


def test_bad_bool_override():
    with pytest.raises(TypeError, match="terminate_on_collision.*bool"):
        marl_social.parallel_env(terminate_on_collision="yes")


def test_unknown_scenario_and_render_mode():
    with pytest.raises(ValueError, match="unknown scenario 'highway'.*occluded_crosswalk"):
        marl_social.parallel_env(scenario="highway")
    with pytest.raises(ValueError, match="render_mode"):
        marl_social.parallel_env(render_mode="ascii")
    with pytest.raises(ValueError, match="max_cycles"):
        marl_social.parallel_env(max_cycles=0)
