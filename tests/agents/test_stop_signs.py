"""The robot planner at a stop sign: it stops at the line gently, waits at rest, then goes."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.agents.robot.planner import RobotPlanner
from marl_social.agents.robot.settings import RobotSettings
from marl_social.agents.robot.stages import StopLines
from marl_social.agents.robot.stop import StopSigns, stop_sign_arc_lengths
from marl_social.envs.world import World
from marl_social.scenarios.base import ScenarioLayout, ScenarioParams
from marl_social.scenarios.roads import straight_lane, straight_route
from marl_social.sim.agent_spec import AgentSpec, VehicleParams
from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import ObservationLayout
from marl_social.sim.road_map import Lane, RoadMap, StopLine

LINE_X = 100.0  # the stop line across the lane at x = 100 m
HALF_LENGTH = 0.5 * VehicleParams().length_m


def _map(stop_lines=(), reverse_lane: bool = False) -> RoadMap:
    """A straight road along +x at y = 0 (and, with reverse_lane, a lane 1 running -x)."""
    lanes = (straight_lane(-10.0, 400.0, 0.0),)
    if reverse_lane:
        lanes += (Lane(lanes[0].centerline[::-1].copy(), lanes[0].width_m),)
    return RoadMap(lanes=lanes, crosswalks=(), static_polygons=(),
                   routes={"robot_0": straight_route("robot_0", -10.0, 400.0, 0.0)},
                   stop_lines=tuple(stop_lines), extent=(-10.0, 400.0, -20.0, 20.0))


def _line(kind="stop_sign", lane=0) -> StopLine:
    return StopLine(np.array([[LINE_X, -1.75], [LINE_X, 1.75]]), kind, lane)


def _drive(road_map: RoadMap, x0: float, v0: float, n_steps: int = 250, planner=None):
    """Closed loop of the social robot alone on `road_map`: (T,) x [m] and speed [m/s]."""
    spec = AgentSpec("robot_0", "vehicle", "robot", np.array([x0, 0.0, 0.0, v0]),
                     v_desired_mps=12.0)
    params = ScenarioParams(n_rays=16)
    world = World(ScenarioLayout(road_map, (spec,), params))
    layout = ObservationLayout(params.n_slots, params.n_rays)
    planner = planner or RobotPlanner(spec, layout, road_map, ["robot_0"],
                                       RobotSettings(planner="social"))
    planner.reset()
    rng = np.random.default_rng(0)
    x, v = [x0], [v0]
    for _ in range(n_steps):
        fov, meas = world.perceive(rng)
        obs = layout.encode(world.bodies(), meas, fov.depth_m)
        world.step(planner(obs[0])[None].astype(np.float64))
        x.append(world.state[0, 0])
        v.append(world.state[0, 3])
    return np.array(x), np.array(v), planner


STARTS = [(float(d), float(v)) for d, v in zip(np.random.default_rng(5).uniform(40.0, 90.0, 4),
                                                np.random.default_rng(6).uniform(6.0, 12.0, 4))]


@pytest.mark.parametrize("distance_m, speed_mps", STARTS)
def test_robot_stops_at_a_stop_sign_gently_waits_then_goes(distance_m, speed_mps):
    """From 40-90 m before the line at 6-12 m/s: it brakes comfortably (<= 3 m/s^2), its
    front never crosses the line before it has stood within 1.5 m of it for 0.5 s, then it
    drives on past the line back to speed."""
    x, v, _ = _drive(_map([_line()]), LINE_X - HALF_LENGTH - distance_m, speed_mps)
    front = x + HALF_LENGTH
    decel = -np.diff(v) / DT_S
    at_line = (v < 0.1) & (np.abs(front - LINE_X) <= 1.5)
    # the first time it has stood at the line for 0.5 s
    held = np.convolve(at_line, np.ones(5, int), mode="valid") == 5
    assert held.any(), f"never stood at the line: closest {LINE_X - front.max():.2f} m"
    k_go = int(np.flatnonzero(held)[0]) + 5
    assert np.all(front[:k_go] <= LINE_X + 0.1)
    assert decel[:k_go].max() <= 3.0
    assert front[-1] > LINE_X + 20.0 and v[-1] > 8.0  # it went on


def test_without_a_stop_sign_nothing_changes():
    """No stop line or a signal's (not the robot planner's: ignored): the same drive, at speed
    all the way; a stop sign for the other direction of travel does not apply either."""
    x0, v0 = LINE_X - 60.0, 10.0
    plain_x, plain_v, _ = _drive(_map(), x0, v0, 120)
    assert plain_v.min() > 9.0
    for road_map in (_map([_line("signal")]), _map([_line(lane=1)], reverse_lane=True)):
        x, v, _ = _drive(road_map, x0, v0, 120)
        np.testing.assert_array_equal(x, plain_x)
        np.testing.assert_array_equal(v, plain_v)


def test_stop_sign_state_resets_with_the_planner():
    """After a drive through the stop sign, the same planner reset drives it identically."""
    road_map = _map([_line()])
    x1, v1, planner = _drive(road_map, LINE_X - 50.0, 10.0, 150)
    assert planner.stage(StopLines).stop_signs.next_line == 1  # cleared
    x2, v2, _ = _drive(road_map, LINE_X - 50.0, 10.0, 150, planner=planner)
    np.testing.assert_array_equal(x1, x2)
    np.testing.assert_array_equal(v1, v2)


def test_stop_lines_on_the_route_and_their_state():
    road_map = _map([_line(), StopLine(np.array([[250.0, -1.75], [250.0, 1.75]])),
                     StopLine(np.array([[50.0, 5.0], [50.0, 9.0]]))])  # beside the route
    route = road_map.routes["robot_0"]
    np.testing.assert_allclose(stop_sign_arc_lengths(route, road_map), [110.0, 260.0])
    signs = StopSigns(route, road_map, 2 * HALF_LENGTH)
    # its centre stays behind the first line, still moving
    assert signs.update(50.0, 5.0, DT_S) == pytest.approx(110.0 - HALF_LENGTH)
    s_rest = 110.0 - HALF_LENGTH - 1.0  # at rest, front 1 m before the line
    for _ in range(4):
        assert signs.update(s_rest, 0.0, DT_S) == pytest.approx(110.0 - HALF_LENGTH)
    assert signs.update(s_rest, 0.0, DT_S) == pytest.approx(260.0 - HALF_LENGTH)  # 0.5 s
    assert signs.update(300.0, 10.0, DT_S) == np.inf  # past the second without stopping


@pytest.mark.parametrize("short_m", [2.0, 4.5])
def test_a_robot_at_rest_short_of_the_line_completes_its_stop_there_then_goes(short_m):
    """At rest with its front 2-4.5 m short of the stop line (the first car at it), the robot
    has stopped: it stays where it stands for hold_s, then goes through without a second stop."""
    road_map = _map([_line()])
    x, v, planner = _drive(road_map, LINE_X - HALF_LENGTH - short_m, 0.0, n_steps=60)
    hold = planner.stage(StopLines).stop_signs.config.hold_s
    moved = np.flatnonzero(v >= 0.1)
    assert len(moved) and moved[0] * DT_S >= hold - 1e-9
    assert np.all(np.abs(x[:moved[0]] - x[0]) < 0.02)  # it stays where it stands
    past = np.flatnonzero(x + HALF_LENGTH > LINE_X)
    assert len(past) and np.all(v[moved[0]:past[0]] >= 0.1)  # no second stop at the line
