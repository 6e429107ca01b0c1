"""The sight hold: short of a lane it cannot see, the robot waits for a left-turner that will tell.

agents/robot/sight_hold.py: while the hidden cars that would claim the merge within 3 s weigh
>= epsilon together (each progress x speed bin below it) and a tracked car can still stop
comfortably short of a zone where it gives way to the same traffic, the robot's centre stays
where its front is hold_gap_m short of the merge zone, pulled up to it (the scenario knob
robot_sight_hold, on by default).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import marl_social
from marl_social.agents.robot.mpc_types import MpcConfig
from marl_social.agents.robot.right_of_way import RightOfWay
from marl_social.agents.robot.sight_hold import SightHold, SightHoldConfig
from marl_social.agents.robot.stages import SightHoldStage
from marl_social.agents.robot.stop import StopSignConfig
from marl_social.evaluation.reproduce_intersection import randomized_overrides
from marl_social.evaluation.run import run_episode
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.perception.tracking import TrackSet
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.route_rules import route_conflicts

CAR = VehicleParams()
MPC = MpcConfig()
TIMES = MPC.plan_times_s  # (N,) [s]
EASTBOUND_Y_M = -1.75
SPEED_MPS = 11.0


@pytest.fixture(scope="module")
def layout():
    """The T-intersection with one left-turner: .road_map (the whole map, for the set-up) and
    .social (the social robot's model of the humans, from its own map)."""
    env = marl_social.parallel_env(scenario="t_intersection", hidden_vehicle="near", n_humans=1)
    robot = marl_social.policies(env)["robot_0"]
    env.close()
    return SimpleNamespace(road_map=env.road_map, social=robot.belief.social)


def _hold(layout, enabled: bool = True, **config) -> SightHold:
    road_map = layout.road_map
    row = RightOfWay(road_map.routes["robot_0"], road_map, CAR.length_m)
    return SightHold(row, layout.social, enabled, CAR.length_m, MPC.plan_dt_s, MPC.epsilon,
                     StopSignConfig(), SightHoldConfig(**config))


def _claims(hold: SightHold, layout, x0_m: list[float]):
    """Claims of L = 1 + len(x0_m) branches: "none" (no car), then one eastbound car each."""
    n = len(x0_m) + 1
    x0 = np.array([0.0, *x0_m])
    xy = (np.stack([x0, np.full(n, EASTBOUND_Y_M)], -1)[:, None, None, :]
          + SPEED_MPS * TIMES[None, None, :, None] * np.array([1.0, 0.0]))
    mask = np.ones((n, 1), bool)
    mask[0] = False
    scene = ScenePrediction(xy, np.zeros((n, 1, len(TIMES))), np.full((n, 1), CAR.length_m),
                            np.full((n, 1), CAR.width_m), np.full((n, 1), 2.5),
                            np.zeros((n, 1), bool), mask)
    road_map = layout.road_map
    row = RightOfWay(road_map.routes["robot_0"], road_map, CAR.length_m)
    hidden = np.ones(n, bool)
    hidden[0] = False
    return row.claims(scene, hold.hold_m - 1.0, 0.0, TIMES), hidden


def _left_turner(layout, before_turn_m: float | None) -> TrackSet:
    """One tracked car at 5 m/s on human_0's path (the left-turn lane), its front before_turn_m
    short of its zone (None: no car)."""
    if before_turn_m is None:
        empty = np.zeros(0)
        return TrackSet(np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2)), empty,
                        empty, empty, np.zeros(0, bool), np.zeros(0, bool), empty, empty)
    road_map = layout.road_map
    route = road_map.routes["human_0"]
    zone = _yield_zones(route, road_map)[0]
    s = zone.s_enter_m - 0.5 * CAR.length_m - before_turn_m
    xy, heading = route.point_at(np.array([s]))
    velocity = 5.0 * np.column_stack([np.cos(heading), np.sin(heading)])
    return TrackSet(np.array([2]), xy, velocity, np.array([0.1]), np.array([CAR.length_m]),
                    np.array([CAR.width_m]), np.array([False]), np.array([True]),
                    np.array([0.0]), heading)


def _yield_zones(route, road_map):
    """The zones on a route where it gives way (test set-up)."""
    return [c for c in route_conflicts(route, road_map) if c.yields]


def test_threat_is_the_weight_of_the_hidden_cars_that_reach_the_zone_within_the_horizon(layout):
    hold = _hold(layout)
    claims, hidden = _claims(hold, layout, [-20.0, -25.0, -55.0])  # 2 near, 1 in ~5 s
    weights = np.array([0.9, 0.015, 0.015, 0.07])
    assert hold.threat_mass(claims, weights, hidden, 0) == pytest.approx(0.03)
    # a longer horizon takes the far car in too
    longer = _hold(layout, threat_horizon_s=6.0)
    assert longer.threat_mass(claims, weights, hidden, 0) == pytest.approx(0.1)


def test_the_robot_holds_short_of_the_lane_while_a_left_turner_is_still_to_tell(layout):
    hold = _hold(layout)
    claims, hidden = _claims(hold, layout, [-20.0, -25.0])
    s0 = hold.hold_m - 1.0
    weights = np.array([0.96, 0.015, 0.015])  # each bin below epsilon, together above it
    coming = _left_turner(layout, 10.0)
    at = hold.stop_at(claims, weights, hidden, 0, coming, s0, 0.5)
    zone = RightOfWay(layout.road_map.routes["robot_0"], layout.road_map,
                      CAR.length_m).conflicts[0]
    assert at == hold.hold_m
    assert zone.s_enter_m - (at + 0.5 * CAR.length_m) == pytest.approx(2.5)
    # no left-turner to tell (none tracked; in its turn; 3 m short of it at 5 m/s, too close
    # to stop at 2.5 m/s^2: committed): waiting teaches nothing
    for gone in (_left_turner(layout, None), _left_turner(layout, -1.0),
                 _left_turner(layout, 3.0)):
        assert hold.stop_at(claims, weights, hidden, 0, gone, s0, 0.5) == np.inf
    # the belief has ruled the near car out (what the left-turner driving on tells)
    low = np.array([0.99, 0.005, 0.005])
    assert hold.stop_at(claims, low, hidden, 0, coming, s0, 0.5) == np.inf
    # too fast to stop comfortably short of the hold point: past it
    assert hold.stop_at(claims, weights, hidden, 0, coming, s0, 3.0) == np.inf
    # no stop sign on the route: never
    off = _hold(layout, enabled=False)
    assert off.stop_at(claims, weights, hidden, 0, coming, s0, 0.5) == np.inf


def test_bad_config_is_rejected():
    with pytest.raises(ValueError, match="threat_horizon_s"):
        SightHoldConfig(threat_horizon_s=0.0)
    with pytest.raises(ValueError, match="hold_gap_m"):
        SightHoldConfig(hold_gap_m=-1.0)
    with pytest.raises(ValueError, match="comfort_decel_mps2"):
        SightHoldConfig(comfort_decel_mps2=0.0)


def _front_gap(result) -> np.ndarray:
    """(T+1,) how far the robot's front is short of its merge zone [m]."""
    trace, road_map = result.trace, result.road_map
    route = road_map.routes["robot_0"]
    zone = _yield_zones(route, road_map)[0]
    s, _, _ = route.project(trace.states[:, trace.index("robot_0"), :2])
    return zone.s_enter_m - (s + 0.5 * CAR.length_m)


def test_the_robot_waits_for_the_left_turner_instead_of_rolling_out_in_front_of_v3():
    """Seed 34 of the claims: the left-turner 15 m from its turn shows nothing of V3 (V3 passes
    first). Without the hold (robot_sight_hold=False) the social robot rolls out on its prior
    at 2 m/s, V3 sees it first and brakes at 6-8 m/s^2; with it, it pulls up to 2.5 m short of
    the lane and stands there until it sees V3."""
    overrides = {**randomized_overrides(34), "robot_sight_hold": True}
    near = run_episode("t_intersection", seed=34, robot_planner="social", hidden_vehicle="near",
                       max_cycles=60, **overrides)
    assert near.metrics["others_max_decel_mps2"] <= 3.0
    trace = near.trace
    v3 = trace.index(f"human_{trace.roles.count('human') - 1}")
    seen = np.flatnonzero(trace.visible[:, trace.index("robot_0"), v3])[0]
    gap = _front_gap(near)
    assert np.all(gap[:seen + 1] >= 2.5 - MPC.position_tolerance_m)
    # stopped at its line 3.45 m short, it pulls up to the hold point (creeping on at < 0.1
    # m/s it would still stand ~3.4 m short when it sees V3) and waits there
    assert gap[:seen + 1].min() <= 2.5 + SightHoldConfig().at_point_m
    # it is the left-turner it waits for: with no left-turner it goes on its prior
    alone = run_episode("t_intersection", seed=34, robot_planner="social",
                        hidden_vehicle="none", max_cycles=30, **{**overrides, "n_humans": 0})
    assert _front_gap(alone).min() < 2.0
    # without the hold it rolls out in front of V3
    rolls = run_episode("t_intersection", seed=34, robot_planner="social", hidden_vehicle="near",
                        max_cycles=30, **{**overrides, "robot_sight_hold": False})
    assert rolls.metrics["others_max_decel_mps2"] > 3.0


def test_the_knob_turns_it_on_at_a_stop_sign_only():
    """robot_sight_hold (on by default) reaches the planner; at a signal it never holds."""
    def active(scenario, **knobs):
        env = marl_social.parallel_env(scenario=scenario, **knobs)
        policy = marl_social.policies(env)["robot_0"]
        env.close()
        return policy.stage(SightHoldStage) is not None

    assert active("t_intersection")
    assert not active("t_intersection", robot_sight_hold=False)
    assert not active("signalized_intersection")
    with pytest.raises(TypeError, match="robot_sight_hold: expected a bool"):
        marl_social.parallel_env(scenario="t_intersection", robot_sight_hold="yes")
