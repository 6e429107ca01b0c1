"""The contingency MPC as a QP: constraints, non-anticipativity, belief weighting, fallback."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.agents.robot import mpc as mpc_module
from marl_social.agents.robot.corridor import (
    Clearances,
    StaticObstacles,
    mode_bounds,
    objects_on_path,
    static_outlines,
)
from marl_social.agents.robot.mpc import ContingencyMpc, distinct_branches, plan
from marl_social.agents.robot.mpc_types import MpcConfig, PlanRequest
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.dynamics import DT_S, bicycle_step
from marl_social.sim.road_map import Route

ROUTE = Route([[-50.0, 1.75], [200.0, 1.75]])  # s = x + 50
CONFIG = MpcConfig()
TIMES = CONFIG.plan_times_s
VEHICLE = VehicleParams()
CROSSWALK_X = 40.0


def _scene(pedestrian_walks: list[bool], start_y: float = -4.5,
           speed_mps: float = 1.3) -> ScenePrediction:
    """One hypothesis per entry: a pedestrian walking across the road at x = 40 (True) or none."""
    n = len(pedestrian_walks)
    start = np.array([CROSSWALK_X, start_y])
    xy = np.broadcast_to(start + np.outer(TIMES * speed_mps, [0.0, 1.0]), (n, 1, len(TIMES), 2))
    return ScenePrediction(
        xy=xy.copy(), heading=np.full((n, 1, len(TIMES)), np.pi / 2),
        length_m=np.full((n, 1), 0.6), width_m=np.full((n, 1), 0.6),
        radius_m=np.full((n, 1), 0.3), is_pedestrian=np.ones((n, 1), bool),
        mask=np.array(pedestrian_walks)[:, None],
    )


def _empty(n_hyp: int = 1) -> ScenePrediction:
    z = np.zeros((n_hyp, 0))
    return ScenePrediction(np.zeros((n_hyp, 0, len(TIMES), 2)), np.zeros((n_hyp, 0, len(TIMES))),
                           z, z, z, z.astype(bool), z.astype(bool))


def _plan(beliefs, walks, s0=30.0, v0=11.5, **kw):
    return plan(CONFIG, VEHICLE, ROUTE, PlanRequest(s0, v0, 0.0, 11.5, 13.9, _scene(walks, **kw),
                np.array(beliefs)))


def _rollout(v0: float, accel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speeds and progress (N,) of an acceleration plan through the simulator's vehicle model."""
    state = np.array([[0.0, 0.0, 0.0, v0]])
    v, s = [], []
    for a in accel:
        state = bicycle_step(state, np.array([[a, 0.0]]), np.array([VEHICLE.wheelbase_m]),
                             np.array([VEHICLE.speed_max_mps]), CONFIG.plan_dt_s)
        v.append(state[0, 3])
        s.append(state[0, 0])
    return np.array(v), np.array(s)


def test_no_hazard_keeps_speed():
    res = _plan([1.0], [False])
    assert res.feasible
    assert res.accel_mps2 == pytest.approx(0.0, abs=1e-3)


def test_solution_meets_every_branch_constraint_through_the_vehicle_model():
    """Three branches (none, a pedestrian crossing now, one crossing later): each branch's
    plan, rolled out through bicycle_step, keeps its speed, acceleration, jerk and corridor
    bounds."""
    s0, v0 = 60.0, 11.5  # 30 m before the crosswalk
    scene = _scene([False, True, True])
    scene.xy[2] = scene.xy[1] - np.array([0.0, 2.0])  # the third one starts 2 m further out
    res = plan(CONFIG, VEHICLE, ROUTE, PlanRequest(
        s0, v0, 0.0, 11.5, 13.9, scene, np.array([0.5, 0.3, 0.2])))
    assert res.feasible and res.live.all()
    objects = objects_on_path(ROUTE, scene, s0, VEHICLE.length_m, VEHICLE.width_m,
                              Clearances(CONFIG.lateral_margin_m))
    h = CONFIG.headway_s()
    tol = 1e-3
    for b in range(3):
        accel = res.accel_plan[b]
        v, s = _rollout(v0, accel)
        assert np.allclose(v, res.speed_plan[b], atol=1e-3)
        assert np.allclose(s, res.progress_plan[b], atol=1e-3)
        assert np.all(v >= -tol) and np.all(v <= 13.9 + tol)
        assert np.all(accel >= -VEHICLE.brake_max_mps2 - tol)
        assert np.all(accel <= VEHICLE.accel_max_mps2 + tol)
        assert abs(accel[0]) <= CONFIG.jerk_max_mps3 * 0.1 + tol
        assert np.all(np.abs(np.diff(accel)) <= CONFIG.jerk_max_mps3 * CONFIG.plan_dt_s + tol)
        s_low, s_up = mode_bounds(objects[b], res.modes[b], CONFIG.n_steps, s0,
                                  VEHICLE.length_m, CONFIG.min_gap_m,
                                  round(CONFIG.pass_margin_s / CONFIG.plan_dt_s))
        assert np.all(s >= s_low - tol)
        assert np.all(s + h * v <= s_up + tol)
    assert res.modes[1] == ("behind",)


def test_shared_first_segment_is_identical_across_branches():
    res = _plan([0.6, 0.4], [False, True], s0=60.0)
    trunk = res.accel_plan[:, :CONFIG.n_trunk]
    assert np.array_equal(trunk[0], trunk[1])
    # and the branches differ after it: the contingency plan brakes, the other does not
    assert res.accel_plan[1, -8:].mean() < res.accel_plan[0, -8:].mean() - 0.1


def test_one_hypothesis_at_certainty_is_a_plain_mpc():
    """b = 1 on one hypothesis: the same plan as that hypothesis alone, and as two copies of
    it at b = 0.5 each (every branch is then the same plain MPC)."""
    alone = _plan([1.0], [True], s0=60.0)
    with_tail = _plan([0.0, 1.0], [False, True], s0=60.0)
    copies = _plan([0.5, 0.5], [True, True], s0=60.0)
    assert not with_tail.live[0]
    np.testing.assert_allclose(with_tail.accel_plan[0], alone.accel_plan[0], atol=1e-3)
    np.testing.assert_allclose(copies.accel_plan[0], alone.accel_plan[0], atol=1e-3)
    np.testing.assert_allclose(copies.accel_plan[1], alone.accel_plan[0], atol=1e-3)


@pytest.mark.parametrize("v0, distance_m", [(11.5, 35.0), (10.0, 25.0), (8.0, 20.0)])
def test_stop_line_gives_a_gentle_deceleration_close_to_v2_over_2d(v0, distance_m):
    """A wall across the lane `distance_m` ahead of the robot's front (plus the gap): the plan
    brakes with a peak close to v^2 / 2d, far from the limit."""
    s0 = 100.0
    x_front = s0 - 50.0 + 0.5 * VEHICLE.length_m
    wall_x = x_front + distance_m + CONFIG.min_gap_m
    boxes = _outlines(np.array([[wall_x, 0.0, wall_x + 2.0, 3.5]]))
    res = plan(CONFIG, VEHICLE, ROUTE, PlanRequest(
        s0, v0, 0.0, 11.5, 13.9, _empty(), np.array([1.0]),
               boxes))
    assert res.feasible
    peak = -res.accel_plan.min()
    ideal = v0 ** 2 / (2.0 * distance_m)
    assert 0.8 * ideal <= peak <= 1.6 * ideal
    assert peak < 0.5 * VEHICLE.brake_max_mps2
    assert res.progress_plan[0, -1] <= distance_m + 1e-3


def test_certain_crossing_pedestrian_makes_it_brake():
    far = _plan([1.0], [True], s0=60.0)
    near = _plan([1.0], [True], s0=72.0)
    assert far.accel_mps2 < 0.0
    assert near.accel_mps2 < far.accel_mps2


def test_unlikely_hypothesis_still_constrains_but_costs_little():
    """b = 0.1 >= epsilon: the robot keeps a stopping branch (defensive) but brakes less now than
    when the pedestrian is certain (not overly conservative)."""
    certain = _plan([0.0, 1.0], [False, True], s0=66.0)
    unlikely = _plan([0.9, 0.1], [False, True], s0=66.0)
    assert unlikely.feasible and certain.feasible
    assert certain.accel_mps2 < unlikely.accel_mps2 < 0.0
    assert unlikely.speed_plan[1, -1] == pytest.approx(0.0, abs=0.05)


def test_epsilon_tail_threshold_ignores_rare_hypotheses():
    tail = _plan([0.99, 0.01], [False, True], s0=72.0)
    none = _plan([1.0], [False], s0=72.0)
    assert not tail.live[1]
    assert tail.accel_mps2 == pytest.approx(none.accel_mps2, abs=1e-6)


def test_beliefs_are_renormalized_over_live_hypotheses():
    res = _plan([0.5, 0.3, 0.2], [False, True, True], s0=60.0)
    assert res.weights.sum() == pytest.approx(1.0)
    assert res.weights == pytest.approx([0.5, 0.3, 0.2])


def _crossing_car(arrival_s: float) -> ScenePrediction:
    """A car crossing the robot's path at x = 40 from the right, at 8 m/s, reaching the
    robot's lane centre after `arrival_s`."""
    y = 1.75 + 8.0 * (TIMES - arrival_s)
    xy = np.stack([np.full_like(TIMES, CROSSWALK_X), y], axis=-1)[None, None]
    return ScenePrediction(xy, np.full((1, 1, len(TIMES)), np.pi / 2), np.array([[4.5]]),
                           np.array([[1.8]]), np.array([[2.4]]), np.array([[False]]),
                           np.array([[True]]))


def test_passes_before_a_crossing_car_that_arrives_late():
    """A car crossing the robot's path 5.5 s from now, the robot 2 s from the crossing: it
    passes before the car arrives, with the time margin, instead of stopping; a car arriving
    in 1.5 s makes it stay behind."""
    late = plan(CONFIG, VEHICLE, ROUTE, PlanRequest(70.0, 11.5, 0.0, 11.5, 13.9, _crossing_car(5.5),
                np.array([1.0])))
    soon = plan(CONFIG, VEHICLE, ROUTE, PlanRequest(70.0, 11.5, 0.0, 11.5, 13.9, _crossing_car(1.5),
                np.array([1.0])))
    assert late.feasible and late.modes[0] == ("past",)
    assert late.accel_mps2 >= -0.1
    assert soon.feasible and soon.modes[0] == ("behind",) and soon.accel_mps2 < 0.0


def test_yields_to_a_pedestrian_it_could_pass_in_front_of():
    """The same timing with a pedestrian (5.3 s from the robot's lane): it has the right of
    way, the robot stays behind; it passes in front of a pedestrian only if it cannot stop."""
    yields = _plan([1.0], [True], s0=70.0, start_y=-6.5)
    assert yields.feasible and yields.modes[0] == ("behind",) and yields.accel_mps2 < 0.0
    # 9 m before the crosswalk at 11.5 m/s, a slow pedestrian 2.4 m from the road: no stop in
    # time even with the jerk bound relaxed, but the robot is past long before it arrives
    cannot_stop = _plan([1.0], [True], s0=81.0, start_y=-6.0, speed_mps=0.5)
    assert cannot_stop.feasible and cannot_stop.modes[0] == ("past",)


def test_no_feasible_plan_brakes_as_hard_as_possible():
    # 6 m before the crosswalk at 11.5 m/s with the pedestrian already in the lane
    res = _plan([1.0], [True], s0=84.0, start_y=1.0, speed_mps=0.0)
    assert not res.feasible
    assert res.accel_mps2 == -VEHICLE.brake_max_mps2


def _outlines(boxes: np.ndarray) -> np.ndarray:
    """(S, 8, 2) the outline points of (S, 4) axis-aligned boxes [xmin, ymin, xmax, ymax]."""
    return static_outlines([np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
                            for x0, y0, x1, y1 in boxes])


def test_static_polygon_ahead_is_a_constraint():
    boxes = _outlines(np.array([[110.0, 0.0, 118.0, 3.5]]))  # robot at s0 = 130: x = 80
    free = plan(CONFIG, VEHICLE, ROUTE, PlanRequest(
        130.0, 11.5, 0.0, 11.5, 13.9, _empty(), np.array([1.0])))
    blocked = plan(CONFIG, VEHICLE, ROUTE, PlanRequest(130.0, 11.5, 0.0, 11.5, 13.9, _empty(),
                   np.array([1.0]), boxes))
    beside = plan(CONFIG, VEHICLE, ROUTE, PlanRequest(130.0, 11.5, 0.0, 11.5, 13.9, _empty(),
                  np.array([1.0]), _outlines(np.array([[110.0, 4.5, 118.0, 8.0]]))))
    assert free.accel_mps2 == pytest.approx(0.0, abs=1e-3)
    assert beside.accel_mps2 == pytest.approx(0.0, abs=1e-3)
    assert blocked.feasible and blocked.accel_mps2 < 0.0


def test_a_diagonal_building_beside_a_diagonal_street_is_no_wall():
    """A polygon along a 45-degree route, 6 m to its side: its bounding box covers the route,
    the polygon does not; one across the route is a wall."""
    route = Route(np.array([[0.0, 0.0], [100.0, 100.0]]))
    along, normal = np.array([1.0, 1.0]) / np.sqrt(2.0), np.array([-1.0, 1.0]) / np.sqrt(2.0)

    def box(s_m: float, lateral_m: float, half_length_m: float, half_width_m: float):
        c = s_m * along + lateral_m * normal
        a, w = half_length_m * along, half_width_m * normal
        return np.array([c - a - w, c + a - w, c + a + w, c - a + w])

    beside = StaticObstacles.project(route, static_outlines([box(60.0, 6.0, 10.0, 2.0)]),
                                     VEHICLE.width_m, CONFIG.lateral_margin_m)
    across = StaticObstacles.project(route, static_outlines([box(60.0, 0.0, 1.0, 5.0)]),
                                     VEHICLE.width_m, CONFIG.lateral_margin_m)
    assert not beside.in_corridor[0] and beside.limit(10.0, VEHICLE.length_m) == np.inf
    assert across.limit(10.0, VEHICLE.length_m) == pytest.approx(59.0)


def test_static_outlines_pad_short_polygons_with_a_vertex():
    triangle = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]])
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    outlines = static_outlines([triangle, square])
    assert outlines.shape == (2, 8, 2)
    np.testing.assert_array_equal(outlines[0, 3:6], [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    np.testing.assert_array_equal(outlines[0, 6:], [[0.0, 0.0], [0.0, 0.0]])
    assert static_outlines([]).shape == (0, 0, 2)


def test_follows_a_slower_car_ahead_with_a_gap():
    """A car 25 m ahead in the lane at 8 m/s: the robot slows to follow it, never closer than
    the gap and the time headway."""
    t = TIMES
    xy = np.stack([100.0 + 8.0 * t, np.full_like(t, 1.75)], axis=-1)[None, None]
    scene = ScenePrediction(xy, np.zeros((1, 1, len(t))), np.array([[4.5]]), np.array([[1.8]]),
                            np.array([[2.4]]), np.array([[False]]), np.array([[True]]))
    res = plan(CONFIG, VEHICLE, ROUTE, PlanRequest(
        125.0, 11.5, 0.0, 11.5, 13.9, scene, np.array([1.0])))
    assert res.feasible and res.accel_mps2 < 0.0
    gap = (150.0 + 8.0 * t - 2.25) - (125.0 + res.progress_plan[0] + 2.25)
    assert np.all(gap >= CONFIG.min_gap_m + CONFIG.headway_s() * res.speed_plan[0] - 1e-3)
    assert res.speed_plan[0, -1] == pytest.approx(8.0, abs=1.0)


def test_curvature_bounds_the_speed():
    """A 90-degree bend of radius ~10 m ahead: v^2 kappa <= a_lat near it."""
    arc = [[60.0 + 10.0 * np.sin(a), 11.75 - 10.0 * np.cos(a)]
           for a in np.linspace(0.0, np.pi / 2, 12)]
    route = Route([[0.0, 1.75], *arc, [70.0, 60.0]])
    res = plan(CONFIG, VEHICLE, route, PlanRequest(
        30.0, 11.5, 0.0, 11.5, 13.9, _empty(), np.array([1.0])))
    assert res.feasible and res.accel_mps2 < 0.0
    bound = np.sqrt(CONFIG.lat_accel_max_mps2 * 10.0)
    s_bend = 60.0 + 2.0  # the bend starts at s = 60 (x = 60)
    in_bend = 30.0 + res.progress_plan[0] >= s_bend
    assert in_bend.any()
    assert np.all(res.speed_plan[0][in_bend] <= bound * 1.15)


def test_car_stopped_in_the_next_lane_does_not_block_the_robot():
    """A stopped car's velocity estimate is noise: its tracked footprint keeps the measured
    heading (along the road), so the robot passing it in its own lane keeps its speed. Turned
    to the direction of the noise (across the road), the 4.5 m car would reach into the
    robot's lane and force it to brake."""
    from marl_social.perception.tracking import Tracker
    from marl_social.sim.observation import EGO_DIM, SLOT_FIELDS, SLOT_INDEX, ObservationLayout

    layout = ObservationLayout(n_slots=2, n_rays=4)
    f = SLOT_INDEX
    tracker = Tracker(pos_noise_m=0.05, vel_noise_mps=0.1)
    rng = np.random.default_rng(3)
    for _ in range(20):  # stopped at x = 95 in the right lane (y = -1.75), heading along +x
        vec = np.zeros(layout.size, dtype=np.float32)
        slot = vec[EGO_DIM:EGO_DIM + len(SLOT_FIELDS)]
        slot[f["present"]], slot[f["id"]] = 1.0, 2.0
        slot[f["x"]], slot[f["y"]] = 95.0 + rng.normal(0, 0.05), -1.75 + rng.normal(0, 0.05)
        slot[f["vx"]], slot[f["vy"]] = 0.0, 0.3  # the noise points across the road
        slot[f["cos_psi"]], slot[f["sin_psi"]] = 1.0, 0.0
        slot[f["length"]], slot[f["width"]] = 4.5, 1.8
        tracks = tracker.update(layout.decode(vec))
    assert tracks.heading_rad[0] == pytest.approx(0.0)
    scene = ScenePrediction.from_tracks(tracks, TIMES[:8])  # 2 s: the drift stays small
    full = ScenePrediction.from_tracks(tracks, TIMES)
    still = ScenePrediction(full.xy.copy(), full.heading, full.length_m, full.width_m,
                            full.radius_m, full.is_pedestrian, full.mask)
    still.xy[..., 1] = scene.xy[..., 0:1, 1]  # no lateral drift beyond the first step
    assert np.allclose(still.heading, 0.0)
    res = plan(CONFIG, VEHICLE, ROUTE, PlanRequest(
        130.0, 11.5, 0.0, 11.5, 13.9, still, np.array([1.0])))
    assert res.feasible and res.accel_mps2 == pytest.approx(0.0, abs=1e-3)
    across = ScenePrediction(still.xy, np.full_like(still.heading, np.pi / 2), still.length_m,
                             still.width_m, still.radius_m, still.is_pedestrian, still.mask)
    blocked = plan(CONFIG, VEHICLE, ROUTE, PlanRequest(130.0, 11.5, 0.0, 11.5, 13.9, across,
                   np.array([1.0])))
    assert blocked.accel_mps2 < 0.0


def test_alike_branches_are_planned_as_one_with_the_same_optimum(monkeypatch):
    """Two branches with the same bounds and comfort factor (the same crossing pedestrian at
    b = 0.3 and 0.2) beside a third: a QP of two branches, whose plans, copied back, are the
    three-branch QP's optimum."""
    scene = _scene([False, True, True])
    beliefs = np.array([0.5, 0.3, 0.2])
    merged_mpc = ContingencyMpc(CONFIG, VEHICLE)
    merged = merged_mpc.plan(ROUTE, PlanRequest(60.0, 11.5, 0.0, 11.5, 13.9, scene, beliefs))
    assert set(merged_mpc._qps) == {2}
    monkeypatch.setattr(mpc_module, "distinct_branches",
                        lambda s_low, s_up, comfort: (np.arange(len(comfort)),
                                                      np.arange(len(comfort))))
    full_mpc = ContingencyMpc(CONFIG, VEHICLE)
    full = full_mpc.plan(ROUTE, PlanRequest(60.0, 11.5, 0.0, 11.5, 13.9, scene, beliefs))
    assert set(full_mpc._qps) == {3}
    assert merged.feasible and full.feasible
    assert np.array_equal(merged.accel_plan[1], merged.accel_plan[2])
    for merged_plan, full_plan in ((merged.accel_plan, full.accel_plan),
                                   (merged.speed_plan, full.speed_plan),
                                   (merged.progress_plan, full.progress_plan)):
        np.testing.assert_allclose(merged_plan, full_plan, atol=1e-6)
    assert merged.cost == pytest.approx(full.cost, rel=1e-9, abs=1e-9)


def test_distinct_branches_groups_equal_rows_only():
    s_low = np.array([[0.0, 1.0], [0.0, 1.0], [0.0, 1.0], [0.0, np.nan], [0.0, np.nan]])
    s_up = np.full((5, 2), np.inf)
    s_up[2, 1] = 9.0
    comfort = np.array([1.0, 1.0, 1.0, 1.0, 1.0])
    first, inverse = distinct_branches(s_low, s_up, comfort)
    assert first.tolist() == [0, 2, 3, 4]  # a NaN bound never equals: not merged
    assert inverse.tolist() == [0, 0, 1, 2, 3]
    comfort[1] = 0.5  # another comfort factor: another branch
    first, inverse = distinct_branches(s_low, s_up, comfort)
    assert first.tolist() == [0, 1, 2, 3, 4] and inverse.tolist() == [0, 1, 2, 3, 4]


def test_qp_is_built_once_per_number_of_branches_and_reused():
    mpc = ContingencyMpc(CONFIG, VEHICLE)
    for s0 in (30.0, 31.0, 32.0):
        mpc.plan(ROUTE, PlanRequest(
            s0, 11.5, 0.0, 11.5, 13.9, _scene([False, True]), np.array([0.7, 0.3])))
    first = mpc._qps[2]
    mpc.plan(ROUTE, PlanRequest(
        33.0, 11.5, 0.0, 11.5, 13.9, _scene([False, True]), np.array([0.7, 0.3])))
    assert mpc._qps[2] is first and set(mpc._qps) == {2}


def test_a_new_mpc_plans_bit_identically_after_others_of_the_same_layout_have_solved():
    """QP layouts are shared between MPCs (qp.py): solving one must not change another's."""

    def episode(mpc):
        plans = [mpc.plan(ROUTE, PlanRequest(s0, v0, 0.0, 11.5, 13.9, _scene([False, True]),
                          np.array([b, 1.0 - b]))).accel_plan
                 for s0, v0, b in ((30.0, 11.5, 0.7), (31.1, 11.0, 0.4), (32.1, 10.2, 0.9))]
        return np.stack(plans)

    first = episode(ContingencyMpc(CONFIG, VEHICLE))
    # other weights and bounds for the same layout (the P values OSQP is updated with differ)
    other = ContingencyMpc(CONFIG, VEHICLE)
    other.plan(ROUTE, PlanRequest(
        20.0, 6.0, -1.0, 11.5, 13.9, _scene([True, True]), np.array([0.05, 0.95])))
    again = episode(ContingencyMpc(CONFIG, VEHICLE))
    assert np.array_equal(first, again)


def _standing(xy: np.ndarray) -> ScenePrediction:
    """One hypothesis: a pedestrian standing at xy (2,) for the whole horizon."""
    scene = _scene([True])
    scene.xy[:] = xy
    return scene


@pytest.mark.parametrize("seed", range(3))
def test_robot_waiting_behind_a_standing_pedestrian_stays_at_rest(seed):
    """A pedestrian stands in the robot's lane for 20 s, its tracked position noisy (5 cm):
    closed loop through the vehicle model, replanning every simulator step, the robot stops
    behind it with the pedestrian gap and, once at rest, stays at rest where it stopped (no
    creeping towards it; the noise alone may move it by a few cm)."""
    rng = np.random.default_rng(seed)
    ped_x = CROSSWALK_X + rng.uniform(-2.0, 2.0)
    mpc = ContingencyMpc(CONFIG, VEHICLE)
    state = np.array([[rng.uniform(5.0, 20.0), 1.75, 0.0, rng.uniform(4.0, 10.0)]])
    prev, speeds, fronts = 0.0, [], []
    for _ in range(round(20.0 / DT_S)):
        ped = np.array([ped_x, 1.75 + rng.uniform(-0.5, 0.5)]) + rng.normal(0.0, 0.05, 2)
        s0, v0 = float(state[0, 0]) + 50.0, float(state[0, 3])
        res = mpc.plan(ROUTE, PlanRequest(
            s0, v0, prev, 11.5, 13.9, _standing(ped), np.array([1.0])))
        assert res.feasible
        prev = res.accel_mps2
        state = bicycle_step(state, np.array([[prev, 0.0]]), np.array([VEHICLE.wheelbase_m]),
                             np.array([VEHICLE.speed_max_mps]))
        speeds.append(state[0, 3])
        fronts.append(state[0, 0] + 0.5 * VEHICLE.length_m)
    speeds, fronts = np.array(speeds), np.array(fronts)
    rest = int(np.argmax(speeds < 0.05))
    assert speeds[rest] < 0.05 and rest * DT_S <= 15.0, rest  # it comes to rest
    assert np.all(speeds[rest:] < 0.05), speeds[rest:].max()
    assert np.ptp(fronts[rest:]) < 0.15, np.ptp(fronts[rest:])
    # behind the pedestrian's near edge (0.3 m) by the gap, up to the position noise
    assert fronts.max() <= ped_x - 0.3 - CONFIG.pedestrian_gap_m + 0.25, (fronts.max(), ped_x)


@pytest.mark.parametrize("n_segments", [1, 2, 7, 30])
def test_project_xy_is_route_project_bit_for_bit(n_segments):
    """Route.project_xy (x and y apart, the corridor's projection) gives Route.project's
    values, bit for bit."""
    rng = np.random.default_rng(n_segments)
    points = np.cumsum(rng.normal(scale=5.0, size=(n_segments + 1, 2)), axis=0)
    route = Route(points)
    xy = np.concatenate([rng.normal(scale=30.0, size=(5, 24, 4, 2)),  # anywhere around it
                         np.broadcast_to(points[:, None, None, :], (n_segments + 1, 24, 4, 2))])
    s_ref, lateral_ref, _ = route.project(xy)
    s, lateral = route.project_xy(xy[..., 0], xy[..., 1])
    assert s.shape == lateral.shape == xy.shape[:-1]
    assert np.array_equal(s, s_ref) and np.array_equal(lateral, lateral_ref)
    # and one point at a time: the values do not depend on the batch
    s1, lateral1 = route.project_xy(xy[3, 5, :, 0].copy(), xy[3, 5, :, 1].copy())
    assert np.array_equal(s1, s_ref[3, 5]) and np.array_equal(lateral1, lateral_ref[3, 5])


class _PublicOsqp:
    """osqp.OSQP's public update/solve behind the calls ContingencyQp makes on the compiled
    solver (update_data_vec, update_data_mat, solve, info, solution, warm_start): the
    reference path."""

    def __init__(self, solver):
        self.solver, self._vec, self._res = solver, {}, None

    def update_data_vec(self, q, l, u):
        self._vec = {"q": q, "l": l, "u": u}

    def update_data_mat(self, P_x, P_i, A_x, A_i):
        self.solver.update(Px=P_x, **self._vec)  # one call, as before the direct path

    def solve(self):
        self._res = self.solver.solve(raise_error=False)

    def warm_start(self, x, y):
        self.solver.warm_start(x=x, y=y)

    @property
    def info(self):
        return self._res.info

    @property
    def solution(self):
        return self._res


def test_direct_solver_calls_match_osqps_public_api_bit_for_bit():
    """qp.py calls OSQP's compiled solver directly (its per-call Python work left out): over a
    sequence of plans (warm starts, a stop, a pass, an infeasible bound) it gives the same
    bits as osqp.OSQP.update / solve. Fails if a new osqp changes what its wrapper does."""

    def episode(public: bool) -> list:
        mpc = ContingencyMpc(CONFIG, VEHICLE)
        qps = [mpc._qp(1), mpc._qp(2), mpc._qp(1, for_modes=True)]  # every QP the plans use
        if public:
            for qp in qps:
                qp._ext = _PublicOsqp(qp._setup_osqp())
        out = []
        for s0, v0, prev, b in ((30.0, 11.5, 0.0, 0.7), (31.1, 11.0, -1.0, 0.4),
                                (32.1, 10.2, -2.0, 0.9), (33.0, 9.8, -2.5, 0.02),
                                (40.0, 3.0, -4.0, 0.5), (47.0, 13.0, 0.0, 1.0)):
            res = mpc.plan(ROUTE, PlanRequest(s0, v0, prev, 11.5, 13.9, _scene([False, True]),
                           np.array([1.0 - b, b])))
            out.append((res.feasible, res.accel_mps2, res.accel_plan.tobytes(), res.cost))
        assert set(mpc._qps) <= {1, 2}
        return out

    direct, public = episode(False), episode(True)
    assert any(r[0] for r in direct) and len({r[1] for r in direct}) > 3  # plans that differ
    assert direct == public
