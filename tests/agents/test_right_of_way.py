"""The robot gives way at the T-intersection's merge zone: a car it merges in front of or follows."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.agents.robot.corridor import route_curvature
from marl_social.agents.robot.mpc import ContingencyMpc
from marl_social.agents.robot.mpc_types import MpcConfig, PlanRequest
from marl_social.agents.robot.right_of_way import RightOfWay, RightOfWayConfig
from marl_social.models.scene_prediction import ScenePrediction
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


def test_an_eastbound_car_claims_the_merge_in_its_own_hypothesis_only(layout):
    """A car coming along the priority lane is, from the step its front reaches the zone, a car
    on the robot's path (the merge is car following, not a crossing); in the hypothesis where it
    is absent, and for a car already past the merge, there is no claim."""
    row = _robot(layout)[2]
    conflict = row.conflicts[0]
    assert row.merges[0] is not None  # the right turn joins the eastbound lane
    s0 = conflict.s_enter_m - 5.0
    scene = _car_scene([-30.0, -30.0, 30.0], EASTBOUND_Y_M, 11.0, mask=[True, False, True])
    claims = row.claims(scene, s0, 0.0, TIMES)
    assert len(claims[0]) == 1 and claims[1] == [] and claims[2] == []
    obj = claims[0][0]
    assert not obj.pass_margin
    # its rear along the robot's route advances at its speed; following it, the robot stays
    # short of the zone until that rear is in there (before the join the rear mapped onto the
    # robot's route lies on the robot's approach, not on the car's lane); claimed from its
    # front's arrival
    dt = np.diff(TIMES)
    entered = obj.s_rear_m > conflict.s_enter_m
    assert entered[-1] and not entered[obj.k_first]
    k_in = int(np.argmax(entered))
    rear = obj.s_rear_m[k_in] + 11.0 * (TIMES - TIMES[k_in])  # the car's rear [m]
    assert np.allclose(obj.s_rear_m, np.maximum(rear, conflict.s_enter_m), atol=1e-6)
    front = rear + CAR.length_m
    assert obj.k_first == np.flatnonzero(front >= conflict.s_enter_m)[0]
    assert obj.k_last == len(TIMES) - 1
    # the front the robot must stay ahead of: the car keeping its speed until the robot's
    # front can first be in its lane (plus follower_reaction_s), then slowing at
    # follower_decel_mps2
    config = row.config
    reaction = row.lane_entry_s(conflict, s0, 0.0) + config.follower_reaction_s
    assert 1.0 < reaction < 6.0  # 5 m short of the zone, from rest, round the corner
    late = TIMES > reaction + 1e-9
    assert np.allclose(obj.s_front_m[~late], front[~late])
    slowed = np.diff(obj.s_front_m) / dt
    expected = np.maximum(11.0 - config.follower_decel_mps2
                          * np.maximum(TIMES[1:] - reaction, 0.0), 0.0)
    assert np.allclose(slowed, expected, atol=1e-6)


def test_a_follower_reacts_when_the_robot_can_first_be_in_its_lane(layout):
    """lane_entry_s: the earliest time the robot's front reaches the lane it merges into, from
    its speed at its acceleration limit and the curve speed of the bend; sooner the nearer and
    the faster the robot, 0 once its front is there."""
    _, route, row = _robot(layout)
    conflict = row.conflicts[0]
    half = 0.5 * CAR.length_m
    at_line = conflict.s_enter_m - half - 1.5
    t_rest = row.lane_entry_s(conflict, at_line, 0.0)
    # from rest its front covers the 1.5 m and the zone (round the bend, at most its curve
    # speed): no sooner than at the acceleration limit all the way, no later than at the
    # curve speed after the ramp
    distance = conflict.s_exit_m - (at_line + half)
    a = row.accel_max_mps2
    assert t_rest >= np.sqrt(2.0 * distance / a) - 1e-9
    vertex_s, kappa = route_curvature(route)
    bend = (vertex_s >= at_line + half) & (vertex_s <= conflict.s_exit_m)
    v_curve = np.sqrt(row.lat_accel_max_mps2 / kappa[bend].max())
    assert t_rest <= v_curve / a + distance / v_curve + 1e-9
    assert row.lane_entry_s(conflict, at_line, 3.0) < t_rest
    assert row.lane_entry_s(conflict, at_line + 3.0, 0.0) < t_rest
    assert row.lane_entry_s(conflict, conflict.s_exit_m - half + 0.1, 2.0) == 0.0


def test_a_westbound_car_or_a_pedestrian_does_not_claim_the_zone(layout):
    _, _, row = _robot(layout)
    s0 = row.conflicts[0].s_enter_m - 5.0
    westbound = _car_scene([30.0], 1.75, 11.0, heading_rad=np.pi)
    assert row.claims(westbound, s0, 0.0, TIMES) == [[]]
    walker = _car_scene([-3.0], EASTBOUND_Y_M, 1.0)
    walker = ScenePrediction(walker.xy, walker.heading, walker.length_m, walker.width_m,
                             walker.radius_m, np.ones((1, 1), bool), walker.mask)
    assert row.claims(walker, s0, 0.0, TIMES) == [[]]


def test_a_committed_robot_is_not_held_back(layout):
    """Once its front is in the zone (beyond committed_m) it clears the zone: no claim."""
    road_map, route, _ = _robot(layout)
    row = RightOfWay(route, road_map, CAR.length_m, RightOfWayConfig(committed_m=0.5))
    enter = row.conflicts[0].s_enter_m
    scene = _car_scene([-30.0], EASTBOUND_Y_M, 11.0)
    assert len(row.claims(scene, enter - 0.5 * CAR.length_m + 0.4, 0.0, TIMES)[0]) == 1
    assert row.claims(scene, enter - 0.5 * CAR.length_m + 0.6, 0.0, TIMES) == [[]]
    with pytest.raises(ValueError, match="committed_m"):
        RightOfWayConfig(committed_m=-1.0)
    with pytest.raises(ValueError, match="follower_decel_mps2"):
        RightOfWayConfig(follower_decel_mps2=0.0)
    with pytest.raises(ValueError, match="follower_reaction_s"):
        RightOfWayConfig(follower_reaction_s=-0.1)


def _plan_at_the_line(layout, x0: float, speed_mps: float):
    """The robot at rest 1.5 m short of the zone, one car x0 [m] west at speed_mps [m/s].

    Returns (robot front (N,) [m], robot speed (N,) [m/s], car front at constant speed
    (N,) [m], the zone's s_enter_m [m], the claim or None, the plan without the claim's
    front (N,) [m]).
    """
    road_map, route, row = _robot(layout)
    conflict = row.conflicts[0]
    s0 = conflict.s_enter_m - 0.5 * CAR.length_m - 1.5
    scene = _car_scene([x0], EASTBOUND_Y_M, speed_mps)
    mpc = ContingencyMpc(MpcConfig(), CAR)
    claims = row.claims(scene, s0, 0.0, TIMES)
    result = mpc.plan(route, PlanRequest(
        s0, 0.0, 0.0, 11.0, road_map.speed_limit_mps, scene, np.ones(1),
                      None, np.inf, extra_objects=claims))
    assert result.feasible
    obj = claims[0][0] if claims[0] else None
    front = s0 + result.progress_plan[0] + 0.5 * CAR.length_m
    plain = mpc.plan(route, PlanRequest(
        s0, 0.0, 0.0, 11.0, road_map.speed_limit_mps, scene, np.ones(1)))
    plain_front = s0 + plain.progress_plan[0] + 0.5 * CAR.length_m
    # the car's front along the robot's route (its lane position mapped past the join; the
    # claim's s_rear_m is never short of the zone, a robot following it stays out of the zone)
    lane, s_join = row.merges[0]
    s_lane, _ = lane.project_xy(scene.xy[0, 0, :, 0], scene.xy[0, 0, :, 1])
    car_front = (None if obj is None
                 else conflict.s_exit_m + (s_lane - s_join) + 0.5 * CAR.length_m)
    return front, result.speed_plan[0], car_front, conflict.s_enter_m, obj, plain_front


@pytest.mark.parametrize("x0, speed_mps", [(-25.0, 11.0), (-25.0, 14.0), (-35.0, 14.0)])
def test_the_mpc_waits_at_the_line_for_a_near_car_and_follows_it(layout, x0, speed_mps):
    """At rest at the stop line, a car 25-35 m west at 11-14 m/s: merging in front would make
    it brake hard, so the robot's plan keeps its front out of the zone until the car has
    reached it, then follows it (front min_gap_m behind its rear)."""
    front, _, car_front, enter, obj, plain_front = _plan_at_the_line(layout, x0, speed_mps)
    k = obj.k_first
    assert front[k] <= enter
    car_rear = car_front - CAR.length_m
    gap = MpcConfig().min_gap_m
    # where the car's rear is still short of the robot's front (the car west of the junction,
    # mapped onto the robot's route) the robot stays where it stands
    start = enter - 1.5  # its front at rest
    assert np.all(front[k:] <= np.maximum(car_rear[k:] - gap, start + 0.2) + 0.05)
    assert front[-1] > start + 1.0  # and it follows the car out
    # without the claim the corridor alone lets it go further (the car enters the robot's
    # corridor only where the route has turned east): the claim is what holds it
    assert plain_front[k] > front[k]


def test_the_mpc_merges_in_front_of_a_car_only_where_it_need_not_brake_hard():
    """Over random cars 15-60 m west at 8-14 m/s, the robot at rest at its line: where its
    plan rolls into the lane before the car gets there, the car (at its speed until then) needs
    at most 2.5 m/s^2 to keep a metre behind it, braking from the moment the robot's front
    enters the zone; a car far enough away does not hold it back, a near one does."""
    layout = make_scenario("t_intersection", hidden_vehicle="near").build(
        np.random.default_rng(0))
    rng = np.random.default_rng(2024)
    merged = waited = 0
    for x0, speed in zip(rng.uniform(-60.0, -15.0, 16), rng.uniform(8.0, 14.0, 16)):
        front, v, car_front, enter, obj, _ = _plan_at_the_line(layout, float(x0), float(speed))
        inside = np.flatnonzero(front > enter)
        if obj is None or (len(inside) and inside[0] < obj.k_first):
            merged += 1
            if obj is None:
                continue  # the car does not reach the zone within the plan
            k = inside[0]
            gap = (front[k] - CAR.length_m) - car_front[k] - 1.0
            assert gap > 0.0, (x0, speed)
            need = max(speed - v[k], 0.0) ** 2 / (2.0 * gap)
            assert need <= 2.5, (x0, speed, need)
        else:
            waited += 1
    assert merged >= 3 and waited >= 3, (merged, waited)


def test_a_robot_rolling_up_to_the_zone_stops_short_of_it_comfortably_for_a_car(layout):
    """Rolling at 1.6 m/s, its front 2.3 m short of the zone (just past its sight-hold point),
    a car 35 m west at 12 m/s: the robot can stop short of the zone at under 1 m/s^2, and its
    plan does, then follows the car. Mapped onto the robot's route before the join, the car's
    rear lies on the robot's approach: staying a car length short of it was infeasible, and the
    robot braked at its limit (seed 7 of the T-intersection claims, a hidden-car branch)."""
    road_map, route, row = _robot(layout)
    conflict = row.conflicts[0]
    config = MpcConfig()
    s0 = conflict.s_enter_m - 0.5 * CAR.length_m - 2.3
    scene = _car_scene([-35.0], EASTBOUND_Y_M, 12.0)
    claims = row.claims(scene, s0, 1.6, TIMES)
    (obj,) = claims[0]
    result = ContingencyMpc(config, CAR).plan(route, PlanRequest(s0, 1.6, 0.0, 11.0,
                                              road_map.speed_limit_mps, scene, np.ones(1),
                                              None, np.inf, extra_objects=claims))
    assert result.feasible and not result.jerk_relaxed
    assert result.accel_mps2 >= -config.comfort_decel_mps2
    front = s0 + result.progress_plan[0] + 0.5 * CAR.length_m
    assert np.all(front[obj.k_first:] <= np.maximum(obj.s_rear_m[obj.k_first:], 0.0)
                  - config.min_gap_m + config.position_tolerance_m)
    assert front[obj.k_first] <= conflict.s_enter_m
