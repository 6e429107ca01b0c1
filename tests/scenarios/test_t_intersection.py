"""The T-intersection scenario (paper Fig. 1 b): map, occlusion by parked cars, agents, knobs."""

from __future__ import annotations

import math

import numpy as np
import pytest

import marl_social
from marl_social.scenarios import make_scenario
from marl_social.scenarios.t_intersection import (
    LEFT_TURN_RADIUS_M,
    NORTHBOUND_X_M,
    STOP_LINE_Y_M,
    TIntersection,
)
from marl_social.sim.route_rules import route_conflicts, stop_line_positions


def _layout(**overrides):
    return TIntersection(**overrides).build(np.random.default_rng(0))


def _visible_at_reset(**overrides) -> dict:
    env = marl_social.parallel_env(scenario="t_intersection", **overrides)
    _, infos = env.reset(seed=0)
    env.close()
    return {a: info["visible"] for a, info in infos.items()}


def test_agents_and_their_names():
    """robot_0, the n_humans left-turners human_0.., and V3 as the last human (if present)."""
    assert [a.name for a in _layout(n_humans=2).agents] == ["robot_0", "human_0", "human_1",
                                                            "human_2"]
    assert [a.name for a in _layout(n_humans=0, hidden_vehicle="none").agents] == ["robot_0"]
    env = marl_social.parallel_env(scenario="t_intersection", n_humans=3)
    assert env.possible_agents == ["robot_0", "human_0", "human_1", "human_2", "human_3"]


def test_map_stop_line_and_turning_paths():
    """The robot's route crosses the stop line once, where the stem meets the main road; the
    left turn is a circular arc of the documented radius; both turning paths are smooth."""
    rm = _layout().road_map
    robot = rm.routes["robot_0"]
    stops = stop_line_positions(robot, rm)
    assert len(stops) == 1
    xy, _ = robot.point_at(stops)
    assert xy[0, 1] == pytest.approx(STOP_LINE_Y_M)
    assert abs(xy[0, 0] - NORTHBOUND_X_M) < 0.5  # in the northbound lane, the turn just begun
    left = rm.routes["human_0"]
    assert len(stop_line_positions(left, rm)) == 0
    centre = np.array([-0.5 * 3.5 + LEFT_TURN_RADIUS_M, STOP_LINE_Y_M])
    arc = left.points[(left.points[:, 1] < 1.7) & (left.points[:, 1] > STOP_LINE_Y_M + 0.1)]
    np.testing.assert_allclose(np.linalg.norm(arc - centre, axis=1), LEFT_TURN_RADIUS_M,
                               atol=1e-9)
    for route in (robot, left):
        heading = np.unwrap(np.arctan2(*np.diff(route.points, axis=0).T[::-1]))
        assert np.abs(np.diff(heading)).max() < math.radians(10.0)


def test_conflict_zones_give_the_eastbound_lane_the_right_of_way():
    rm = _layout().road_map
    assert {z.name for z in rm.conflict_zones} == {"left_turn_crossing", "right_turn_merge"}
    assert all(rm.lanes[z.priority_lanes[0]].name == "eastbound" for z in rm.conflict_zones)
    robot = {c.zone.name: c for c in route_conflicts(rm.routes["robot_0"], rm)}
    assert robot["right_turn_merge"].yields


def test_parked_cars_hide_the_near_car_from_the_robot_but_not_from_the_left_turners():
    """At reset in `near` the robot sees the left-turners but not V3 (behind the parked cars);
    the first left-turner sees V3 (the second one, behind it, sees it once the first one has
    moved aside, before V3 reaches the junction). With few parked cars (a 20 m gap between
    them) the robot sees V3: the parked cars, not the range or the view cone, hide it."""
    seen = _visible_at_reset(hidden_vehicle="near", n_humans=2)
    assert "human_2" not in seen["robot_0"]
    assert {"human_0", "human_1"} <= set(seen["robot_0"])
    assert "human_2" in seen["human_0"]
    trace = marl_social.run_episode("t_intersection", seed=0, hidden_vehicle="near",
                                    robot_planner="cruise", max_cycles=40).trace
    v3 = trace.index("human_2")
    before = trace.states[:, v3, 0] < -4.0  # V3 west of the junction
    assert trace.visible[before, trace.index("human_1"), v3].any()
    sparse = _visible_at_reset(hidden_vehicle="near", n_humans=2, parked_gap_m=20.0)
    assert "human_2" in sparse["robot_0"]


def test_parked_cars_are_solid():
    """A car steered into the parking lane hits a parked car: a collision with "static"."""
    env = marl_social.parallel_env(scenario="t_intersection", n_humans=0, hidden_vehicle="none",
                                   terminate_on_collision=False, max_cycles=200)
    env.reset(seed=0)
    hit = False
    for _ in range(200):
        heading = env.world.state[0, 2]
        steer = 0.6 if heading < math.pi - 0.05 else 0.0  # full lock left until facing west
        _, _, _, _, infos = env.step({"robot_0": np.array([1.0, steer])})
        if "static" in infos["robot_0"]["collided_with"]:
            hit = True
            break
        if not env.agents:
            break
    assert hit


def test_episodes_are_deterministic():
    """Same seed: bit-identical states and metrics (the default robot planner); another seed
    changes the humans' sampled actions."""
    a = marl_social.run_episode("t_intersection", seed=3, max_cycles=40)
    b = marl_social.run_episode("t_intersection", seed=3, max_cycles=40)
    c = marl_social.run_episode("t_intersection", seed=4, max_cycles=40)
    assert np.array_equal(a.trace.states, b.trace.states)
    assert a.metrics.keys() == b.metrics.keys()
    assert all(a.metrics[k] == b.metrics[k] or (a.metrics[k] != a.metrics[k]
                                                 and b.metrics[k] != b.metrics[k])
               for k in a.metrics)
    assert not np.array_equal(a.trace.states, c.trace.states)


@pytest.mark.parametrize("planner", ["social", "cruise", "aggressive"])
def test_robot_planners_run(planner):
    """Every robot planner runs on the intersection map (no crosswalk) and the metrics exist."""
    result = marl_social.run_episode("t_intersection", seed=0, max_cycles=30,
                                     robot_planner=planner)
    assert {"yielded", "time_to_pass_s", "others_max_decel_mps2"} <= set(result.metrics)
    assert result.metrics["others_max_decel_mps2"] >= 0.0


@pytest.mark.parametrize(("overrides", "field"), [
    ({"hidden_vehicle": "behind"}, "hidden_vehicle"),
    ({"n_humans": 4}, "n_humans"),
    ({"n_humans": -1}, "n_humans"),
    ({"hidden_near_m": 80.0, "hidden_far_m": 60.0}, "hidden_far_m"),
    ({"hidden_speed_mps": -1.0}, "hidden_speed_mps"),
    ({"parked_gap_m": -0.5}, "parked_gap_m"),
    ({"parked_gap_m": float("inf")}, "parked_gap_m"),
    ({"human_beta": -2.0}, "human_beta"),
    ({"human_start_m": 500.0}, "human_start_m"),
    ({"robot_half_fov_deg": 0.0}, "robot_half_fov_deg"),
    ({"human_theta": [1.0, 2.0]}, "human_theta"),
    ({"robot_theta_hat": {"speed": "fast"}}, "robot_theta_hat"),
    ({"robot_theta_hat": "no/such/theta.json"}, "robot_theta_hat"),
    ({"robot_start_back_m": -1.0}, "robot_start_back_m"),
])
def test_bad_knobs_name_the_field(overrides, field):
    with pytest.raises(ValueError, match=f"TIntersectionParams.{field}"):
        make_scenario("t_intersection", **overrides)


def test_unknown_knob_is_rejected():
    with pytest.raises(ValueError, match="unknown scenario parameter.*pedestrian"):
        make_scenario("t_intersection", pedestrian="crossing")


@pytest.mark.parametrize("scenario", ["t_intersection", "signalized_intersection"])
def test_the_robots_model_of_the_humans_takes_cost_weights_or_an_irl_fit(scenario, tmp_path):
    """robot_theta_hat, as at the crosswalk: weights (a mapping) or a `marl-social irl fit`
    file reach the robot's belief (its model of the humans); () keeps its default."""
    import json

    from marl_social.perception.belief.config import ROBOT_THETA_HAT
    from marl_social.sim.costs import CostWeights

    def theta_hat(**overrides) -> np.ndarray:
        env = marl_social.parallel_env(scenario=scenario, **overrides)
        robot = marl_social.policies(env)["robot_0"]
        env.close()
        return robot.belief.config.theta_hat.as_array()

    np.testing.assert_array_equal(theta_hat(), ROBOT_THETA_HAT.as_array())
    weights = {"speed": 2.0, "accel": 0.3, "jerk": 0.1, "safety": 4.0, "crosswalk": 800.0}
    np.testing.assert_array_equal(theta_hat(robot_theta_hat=weights),
                                  CostWeights(**weights).as_array())
    direction = np.array([1.0, 0.1, 0.1, 1.0, 1000.0])
    fit = {"format": "marl-social-irl/1",
           "features": ["tracking", "speed", "accel", "jerk", "safety", "crosswalk"],
           "fitted": ["speed", "accel", "jerk", "safety", "crosswalk"],
           "theta": [None, *(2.0 * direction).tolist()],
           "direction": [None, *(direction / np.linalg.norm(direction)).tolist()],
           "scale": 2.0 * float(np.linalg.norm(direction))}
    (tmp_path / "theta.json").write_text(json.dumps(fit))
    learned = theta_hat(robot_theta_hat=str(tmp_path / "theta.json"))
    np.testing.assert_allclose(learned[1:] / np.linalg.norm(learned[1:]),
                               direction / np.linalg.norm(direction))
