"""The robot gives way at the T-intersection's merge zone: zone claims and the MPC's plan."""

from __future__ import annotations

import numpy as np
import pytest
from marl_social.agents.robot.mpc import ContingencyMpc, MpcConfig
from marl_social.agents.robot.right_of_way import RightOfWay, RightOfWayConfig

from marl_social.models.candidates import ScenePrediction
from marl_social.scenarios import make_scenario
from marl_social.sim.agent_spec import VehicleParams

CAR = VehicleParams()
TIMES = MpcConfig().plan_times_s  # (N,) [s]
EASTBOUND_Y_M = -1.75


@pytest.fixture(scope="module")
def layout():
    return make_scenario("t_intersection", hidden_vehicle="near").build(np.random.default_rng(0))


def _car_scene(x0: np.ndarray, y: float, speed_mps: float, heading_rad: float = 0.0,
               mask=None) -> ScenePrediction:
    """L hypotheses, one car each at (x0[l], y) driving at speed along heading (constant)."""
    x0 = np.asarray(x0, dtype=np.float64)
    n, t = len(x0), len(TIMES)
    d = np.array([np.cos(heading_rad), np.sin(heading_rad)])
    xy = (np.stack([x0, np.full(n, y)], -1)[:, None, None, :]
          + speed_mps * TIMES[None, None, :, None] * d)
    mask = np.ones((n, 1), bool) if mask is None else np.asarray(mask, bool).reshape(n, 1)
    return ScenePrediction(xy, np.full((n, 1, t), heading_rad), np.full((n, 1), CAR.length_m),
                           np.full((n, 1), CAR.width_m),
                           np.full((n, 1), 0.5 * np.hypot(CAR.length_m, CAR.width_m)),
                           np.zeros((n, 1), bool), mask)


def _robot(layout):
    road_map = layout.road_map
    route = road_map.routes["robot_0"]
    row = RightOfWay(route, road_map, CAR.length_m)
    return road_map, route, row


def test_the_robot_yields_at_the_merge_zone_only(layout):
    _, _, row = _robot(layout)
    assert [c.zone.name for c in row.conflicts] == ["right_turn_merge"]


def test_an_eastbound_car_claims_the_zone_in_its_own_hypothesis_only(layout):
    """A car coming along the priority lane claims the zone while it is predicted there; in the
    hypothesis where it is absent, and for a car that has passed, there is no claim."""
    row = _robot(layout)[2]
    conflict = row.conflicts[0]
    s0 = conflict.s_enter_m - 5.0
    scene = _car_scene([-30.0, -30.0, 30.0], EASTBOUND_Y_M, 11.0, mask=[True, False, True])
    claims = row.claims(scene, s0)
    assert len(claims[0]) == 1 and claims[1] == [] and claims[2] == []
    obj = claims[0][0]
    # in the zone (x in [2.5, 14] grown by half a car) between about 2.6 and 4.0 s
    t_first, t_last = TIMES[obj.k_first], TIMES[obj.k_last]
    assert 2.2 <= t_first <= 2.8 and 3.8 <= t_last <= 4.4
    assert np.all(obj.s_rear_m == conflict.s_enter_m) and np.all(obj.s_front_m == conflict.s_exit_m)


def test_a_westbound_car_or_a_pedestrian_does_not_claim_the_zone(layout):
    _, _, row = _robot(layout)
    s0 = row.conflicts[0].s_enter_m - 5.0
    westbound = _car_scene([30.0], 1.75, 11.0, heading_rad=np.pi)
    assert row.claims(westbound, s0) == [[]]
    walker = _car_scene([-3.0], EASTBOUND_Y_M, 1.0)
    walker = ScenePrediction(walker.xy, walker.heading, walker.length_m, walker.width_m,
                             walker.radius_m, np.ones((1, 1), bool), walker.mask)
    assert row.claims(walker, s0) == [[]]


def test_a_committed_robot_is_not_held_back(layout):
    """Once its front is in the zone (beyond committed_m) it clears the zone: no claim."""
    road_map, route, _ = _robot(layout)
    row = RightOfWay(route, road_map, CAR.length_m, RightOfWayConfig(committed_m=0.5))
    enter = row.conflicts[0].s_enter_m
    scene = _car_scene([-30.0], EASTBOUND_Y_M, 11.0)
    assert len(row.claims(scene, enter - 0.5 * CAR.length_m + 0.4)[0]) == 1
    assert row.claims(scene, enter - 0.5 * CAR.length_m + 0.6) == [[]]
    with pytest.raises(ValueError, match="committed_m"):
        RightOfWayConfig(committed_m=-1.0)


@pytest.mark.parametrize("x0", [-25.0, -35.0, -45.0])
def test_the_mpc_waits_at_the_line_for_a_car_with_the_right_of_way(layout, x0):
    """At rest at the stop line, with a car 25-45 m west coming at 11 m/s: the robot's plan
    keeps its front out of the zone until the car has passed through it (it cannot clear the
    zone 2.5 s before the car arrives)."""
    road_map, route, row = _robot(layout)
    conflict = row.conflicts[0]
    s0 = conflict.s_enter_m - 0.5 * CAR.length_m - 1.5
    scene = _car_scene([x0], EASTBOUND_Y_M, 11.0)
    mpc = ContingencyMpc(MpcConfig(), CAR)
    claims = row.claims(scene, s0)
    result = mpc.plan(route, s0, 0.0, 0.0, 11.0, road_map.speed_limit_mps, scene, np.ones(1),
                      None, np.inf, extra_objects=claims)
    assert result.feasible
    obj = claims[0][0]
    front = s0 + result.progress_plan[0] + 0.5 * CAR.length_m
    assert np.all(front[obj.k_first:obj.k_last + 1] <= conflict.s_enter_m)
    # without the claim the corridor alone lets it go further (the car crosses the robot's
    # corridor only where the route has turned east): the claim is what holds it
    plain = mpc.plan(route, s0, 0.0, 0.0, 11.0, road_map.speed_limit_mps, scene, np.ones(1))
    plain_front = s0 + plain.progress_plan[0] + 0.5 * CAR.length_m
    assert plain_front[obj.k_first] > front[obj.k_first]
