"""The compiled kernels (models/gap_kernels.py) against the numpy they stand for, bit for bit.

np.sum's pairwise order (every length, incl. more than 128 values), the candidates' rollouts
with and without a curve speed, the scene's covering circles, the gaps of every plan step to
every object (discs, vehicles,
objects shared by the hypotheses, M >= 8 objects, L > 1 hypotheses, NaN), and
vehicle_gap_evaluation on many objects and hypotheses.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.models import gap_kernels
from marl_social.models.candidates import PlanningEgo, Surroundings, evaluate_candidates
from marl_social.models.circle_gaps import circle_pair_gap, scene_circle_inputs, scene_circles
from marl_social.models.gap_evaluation import vehicle_gap_evaluation
from marl_social.models.rollouts import CandidateSet, _governed, _plan_constants, _rollout
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.sim import pairwise_sum
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.road_map import Crosswalk, Route
from marl_social.sim.route_rules import CURVE_PROFILE_STEP_M, CurveSpeed
from tests.helpers import read_only, same_bits
from tests.models.test_gap_evaluation import _route
from tests.models.test_pedestrian_costs import random_scene

CANDIDATES = CandidateSet((-8.0, -4.0, -1.0, 0.0, 1.0, 2.0), (-2.0, 0.0, 1.0), 0.5, 3.0, 0.25)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 700), rows=st.integers(1, 3))
def test_pairwise_sum_is_np_sum(seed, n, rows):
    rng = np.random.default_rng(seed)
    # magnitudes 1e-17..1: the order of the additions shows in the last bits
    values = rng.random((rows, n)) * 10.0 ** rng.integers(-17, 1, (rows, n))
    want = np.sum(values, axis=-1)
    got = np.array([pairwise_sum.contiguous_sum(row, 0, n) for row in values])
    assert same_bits(got, want)


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), bent=st.booleans(), curve=st.booleans(),
       v0=st.sampled_from([0.0, 0.3, 4.0, 11.0, -0.5]))
def test_plan_poses_is_the_numpy_rollout_and_poses(seed, bent, curve, v0):
    rng = np.random.default_rng(seed)
    route = _route(rng, bent)
    s0 = rng.uniform(-5.0, route.length_m)
    plan = _plan_constants(CANDIDATES)
    dt = CANDIDATES.plan_dt_s
    along = np.array([-1.5, 0.0, 1.5])
    speed = CurveSpeed(route, 2.5, 2.3) if curve else None
    v_max, vertex_s, poses, along = read_only(  # the tables as the planners pass them
        np.zeros(1) if speed is None else speed.v_max_mps, route.vertex_s_m,
        route.segment_pose_table, along)
    v, ds, a_eff, excess, xy, ego_x, ego_y = gap_kernels.plan_poses(
        plan.increments.reshape(-1, CANDIDATES.n_steps), len(CANDIDATES.continuations_mps2),
        v0, s0, dt, plan.continuations, CANDIDATES.n_first, speed is not None, v_max,
        CURVE_PROFILE_STEP_M, vertex_s, poses, along)
    want_v, want_ds, want_a = _rollout(v0, plan.increments, dt)
    if speed is not None:  # evaluate_candidates' curve speed
        want_v, want_ds, want_a = _governed(want_v, want_ds, v0, plan.continuations,
                                            CANDIDATES.n_first, dt,
                                            float(speed.at(s0 + want_ds).min()))
        assert same_bits(excess, (want_v - speed.at(s0 + want_ds)).max(axis=-1).reshape(-1))
    shape = want_v.shape
    assert same_bits(v.reshape(shape), want_v)
    assert same_bits(ds.reshape(shape), want_ds)
    assert same_bits(a_eff.reshape(shape), want_a)
    want_xy, heading = route.point_at(s0 + want_ds)
    assert same_bits(xy.reshape(want_xy.shape), want_xy)
    want_x = want_xy[..., 0] + along[:, None, None, None] * np.cos(heading)
    want_y = want_xy[..., 1] + along[:, None, None, None] * np.sin(heading)
    assert same_bits(ego_x.reshape(want_x.shape), want_x)
    assert same_bits(ego_y.reshape(want_y.shape), want_y)


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 4), n_obj=st.integers(0, 11),
       p_ped=st.sampled_from([0.0, 0.5, 1.0]), shared=st.booleans(), nan=st.booleans())
def test_circle_gaps_is_circle_pair_gap(seed, n_hyp, n_obj, p_ped, shared, nan):
    rng = np.random.default_rng(seed)
    n_t, n_plans = 12, 7
    rows = 1 if shared else n_hyp
    is_ped = np.broadcast_to(rng.random((rows, n_obj)) < p_ped, (n_hyp, n_obj))
    length = np.where(is_ped, 0.6, rng.uniform(3.5, 5.5, (rows, n_obj)))
    width = np.where(is_ped, 0.6, rng.uniform(1.6, 2.2, (rows, n_obj)))
    xy = rng.uniform(-10.0, 10.0, (rows, n_obj, n_t, 2))
    heading = rng.uniform(-4.0, 4.0, (rows, n_obj, n_t))
    full = lambda a: np.ascontiguousarray(np.broadcast_to(a, (n_hyp,) + a.shape[1:]))
    mask = rng.random((n_hyp, n_obj)) < 0.7
    # a frozen scene, as the planners' (its kernel inputs read-only, the kernels' signature)
    scene = ScenePrediction(*read_only(full(xy), full(heading), full(length), full(width),
                                       full(0.5 * np.hypot(length, width)), full(is_ped)),
                            mask)
    ego_x = rng.uniform(-10.0, 10.0, (3, n_plans, n_t))
    ego_y = rng.uniform(-10.0, 10.0, (3, n_plans, n_t))
    if nan:
        ego_x[1, 2, 3] = np.nan
    ox, oy, other_r = scene_circles(scene)
    inputs = scene_circle_inputs(scene)
    compiled_x, compiled_y = gap_kernels.scene_circles(*inputs[:4])
    assert same_bits(compiled_x, ox) and same_bits(compiled_y, oy)
    assert same_bits(inputs[4], other_r)
    want = circle_pair_gap(ego_x, ego_y, 1.1, ox, oy, other_r)  # (L, P, T, M)
    vehicles = mask & ~is_ped
    # the circle centres writable (the planners' kernels build them), the radii read-only
    circles = (np.array(ox, order="C"), np.array(oy, order="C"), inputs[4])
    gap, clearance, vehicle_gap = gap_kernels.circle_gaps(ego_x, ego_y, 1.1, *circles, vehicles,
                                                          False)
    assert same_bits(gap, want)
    want_clearance = np.where(vehicles[:, None, None, :], want, np.inf).min(axis=(-1, -2),
                                                                          initial=np.inf)
    assert same_bits(clearance, want_clearance)
    assert same_bits(vehicle_gap, np.maximum(want_clearance, 0.0))
    clipped, _, _ = gap_kernels.circle_gaps(ego_x, ego_y, 1.1, *circles, vehicles, True)
    assert same_bits(np.exp(clipped), np.exp(-np.maximum(want, 0.0)))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 5),
       n_obj=st.one_of(st.integers(7, 20), st.integers(125, 140)),
       crosswalk=st.booleans(), p_absent=st.sampled_from([0.0, 0.3]), zones=st.integers(0, 2),
       bent=st.booleans())
def test_vehicle_gap_evaluation_with_many_objects(seed, n_hyp, n_obj, crosswalk, p_absent,
                                                  zones, bent):
    """Seven objects and more: from 8 on np.sum's pairwise order, beyond 128 its halving too."""
    rng = np.random.default_rng(seed)
    route = _route(rng, bent)
    scene = random_scene(rng, n_hyp, n_obj, CANDIDATES.n_steps, 0.4, p_absent, (-5.0, 30.0))
    crosswalks = (Crosswalk(center=np.array([20.0, 0.0]), walk_heading_rad=0.5 * np.pi,
                            length_m=10.0, width_m=4.0),) if crosswalk else ()
    args = (CANDIDATES, rng.uniform(0.0, 3.0, 6), rng.uniform(5.0, 12.0), VehicleParams(),
            route, rng.uniform(0.0, 40.0), rng.uniform(0.0, 12.0), rng.uniform(-3.0, 2.0),
            scene, crosswalks)
    polygon = np.array([[10.0, -5.0], [25.0, -5.0], [25.0, 5.0], [10.0, 5.0]])
    extra = {"yield_zones": tuple((polygon + 3.0 * k, rng.random((n_hyp, n_obj)) < 0.6)
                                  for k in range(zones)), "yield_margin_s": 1.5,
             "curve_speed": CurveSpeed(route, 2.5, 2.3) if bent else None}
    ego, around = PlanningEgo(*args[:8]), Surroundings(*args[8:], **extra)
    want = evaluate_candidates(ego, around, geometry=True, vehicle_gaps_only=True)
    got = vehicle_gap_evaluation(ego, around)
    for name in ("step_cost", "v", "a_eff", "travel_m", "min_vehicle_gap_m",
                 "vehicle_clearance_m") + (("curve_excess_mps",) if bent else ()):
        assert same_bits(getattr(got, name), np.asarray(getattr(want, name))), name
        assert np.array_equal(getattr(got, name).sum(axis=-1),
                              getattr(want, name).sum(axis=-1), equal_nan=True), name


def test_a_negative_zero_speed_is_zero_and_out_of_range_states_are_refused():
    """-0.0 is evaluated as 0.0; a non-finite or huge speed or arc length: a ValueError."""
    route = Route([[-60.0, -1.75], [120.0, -1.75]])
    scene = ScenePrediction(np.zeros((1, 0, 12, 2)), np.zeros((1, 0, 12)), np.zeros((1, 0)),
                            np.zeros((1, 0)), np.zeros((1, 0)), np.zeros((1, 0), bool),
                            np.zeros((1, 0), bool))

    def evaluations(s0, v0):
        args = (CANDIDATES, np.ones(6), 8.0, VehicleParams(), route, s0, v0, 0.0, scene, ())
        ego, around = PlanningEgo(*args[:8]), Surroundings(*args[8:])
        return (evaluate_candidates(ego, around, geometry=True, vehicle_gaps_only=True),
                vehicle_gap_evaluation(ego, around))

    (want, got), (zero, _) = evaluations(3.0, -0.0), evaluations(3.0, 0.0)
    for name in ("step_cost", "v", "a_eff", "travel_m"):
        assert same_bits(np.asarray(getattr(got, name)), np.asarray(getattr(want, name)))
        assert same_bits(np.asarray(getattr(got, name)), np.asarray(getattr(zero, name)))
    for s0, v0, what in ((3.0, np.inf, "speed"), (3.0, np.nan, "speed"), (3.0, -2e6, "speed"),
                         (1e13, 2.0, "arc length"), (np.nan, 2.0, "arc length")):
        for evaluate in (evaluate_candidates, vehicle_gap_evaluation):
            args = (CANDIDATES, np.ones(6), 8.0, VehicleParams(), route, s0, v0, 0.0, scene, ())
            with pytest.raises(ValueError, match=f"initial {what}"):
                evaluate(PlanningEgo(*args[:8]), Surroundings(*args[8:]))


def test_a_candidate_set_needs_first_actions_and_continuations():
    for first, continuations in (((), (0.0,)), ((0.0,), ())):
        with pytest.raises(ValueError, match="at least one first action and one continuation"):
            CandidateSet(first, continuations, 0.5, 3.0, 0.25)


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 3), n_obj=st.integers(0, 4),
       n_t=st.sampled_from([1, 2, 3, 24]), p_ped=st.sampled_from([0.0, 0.5, 1.0]),
       p_absent=st.sampled_from([0.0, 0.3]), margin_s=st.sampled_from([0.0, 0.25, 2.0, 3.1]),
       nan=st.booleans())
def test_zone_claims_kernel_is_candidates_zone_claims(seed, n_hyp, n_obj, n_t, p_ped, p_absent,
                                                      margin_s, nan):
    from marl_social.models.candidates import zone_claims
    from marl_social.models.gap_evaluation import _zone_claims
    from marl_social.sim.costs import _polygon_edges

    rng = np.random.default_rng(seed)
    scene = random_scene(rng, n_hyp, n_obj, n_t, p_ped, p_absent, (-12.0, 12.0))
    if nan and n_obj:
        scene.xy[0, 0, rng.integers(n_t), rng.integers(2)] = np.nan
    # a convex zone: a random quadrilateral (or triangle) around the origin, counter-clockwise
    n_vertices = int(rng.integers(3, 6))
    angles = np.sort(rng.uniform(0.0, 2.0 * np.pi, n_vertices))
    polygon = np.stack([np.cos(angles), np.sin(angles)], axis=1) * rng.uniform(2.0, 8.0)
    priority = rng.random((n_hyp, n_obj)) < 0.7
    want = zone_claims(scene, polygon, priority, margin_s, 0.25)
    got = _zone_claims(scene, np.array(_polygon_edges(polygon)), priority, margin_s, 0.25)
    assert same_bits(got, want)
