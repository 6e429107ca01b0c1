"""vehicle_gap_evaluation equals evaluate_candidates(geometry=True, vehicle_gaps_only=True).

Bit for bit, on random scenes: straight and bent routes, crosswalks with and without
pedestrians, objects absent in some hypotheses, hypotheses that share their objects, yield
zones and curve speeds, cost weights with zeros; vehicle_gap_evaluations (several initial speeds,
the scene's work shared) equals vehicle_gap_evaluation from each speed; kernel_rule_totals equals
rule_abiding_totals of that evaluation; and Route.pose_at equals point_at with
np.cos / np.sin of its heading.
"""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from marl_social.models.candidates import PlanningEgo, Surroundings, evaluate_candidates
from marl_social.models.driver import DriverModel, RoadRules, rule_abiding_totals
from marl_social.models.gap_evaluation import (
    kernel_rule_totals,
    vehicle_gap_evaluation,
    vehicle_gap_evaluations,
)
from marl_social.models.rollouts import CandidateSet
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.road_map import Crosswalk, Route
from marl_social.sim.route_rules import CurveSpeed

FIELDS = ("step_cost", "v", "a_eff", "min_gap_m", "conflict", "static_gap_m",
          "min_vehicle_gap_m", "feature_totals", "travel_m", "vehicle_clearance_m",
          "curve_excess_mps")
CANDIDATES = CandidateSet((-8.0, -4.0, -1.0, 0.0, 1.0, 2.0), (-2.0, 0.0, 1.0), 0.5, 3.0, 0.25)


def _route(rng, bent: bool) -> Route:
    if not bent:
        return Route([[-60.0, -1.75], [120.0, -1.75]])
    turn = np.linspace(0.0, 0.5 * np.pi, 12)
    arc = np.column_stack([np.sin(turn), 1.0 - np.cos(turn)]) * rng.uniform(8.0, 15.0)
    return Route(np.vstack([[[-40.0, 0.0]], arc, arc[-1] + [[0.0, 40.0]]]))


def _scene(rng, n_hyp, n_obj, n_t, p_ped, p_absent) -> ScenePrediction:
    shared = rng.random() < 0.5  # hypotheses that repeat the same tracked objects
    rows = 1 if shared else n_hyp
    is_ped = np.broadcast_to(rng.random((rows, n_obj)) < p_ped, (n_hyp, n_obj))
    length = np.where(is_ped, 0.6, rng.uniform(3.5, 5.5, (rows, n_obj)))
    width = np.where(is_ped, 0.6, rng.uniform(1.6, 2.2, (rows, n_obj)))
    xy = rng.uniform(-5.0, 30.0, (rows, n_obj, 1, 2)) + rng.normal(
        size=(rows, n_obj, 1, 2)) * np.arange(1, n_t + 1)[:, None]
    heading = np.repeat(rng.uniform(-4, 4, (rows, n_obj, 1)), n_t, axis=2)
    full = lambda a: np.ascontiguousarray(np.broadcast_to(a, (n_hyp,) + a.shape[1:]))
    return ScenePrediction(full(xy), full(heading), full(length), full(width),
                           full(0.5 * np.hypot(length, width)), full(is_ped),
                           rng.random((n_hyp, n_obj)) >= p_absent)


@settings(max_examples=120, deadline=None)
# every weight zero (found by hypothesis: evaluate_candidates' cost was then a Python float)
@example(seed=29463, n_hyp=2, n_obj=2, bent=True, crosswalk=False, zones=0, p_ped=0.0,
         p_absent=0.0, zero_weights=True)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 3), n_obj=st.integers(0, 4),
       bent=st.booleans(), crosswalk=st.booleans(), zones=st.integers(0, 2),
       p_ped=st.sampled_from([0.0, 0.5, 1.0]), p_absent=st.sampled_from([0.0, 0.3]),
       zero_weights=st.booleans())
def test_vehicle_gap_evaluation_equals_evaluate_candidates(seed, n_hyp, n_obj, bent, crosswalk,
                                                           zones, p_ped, p_absent,
                                                           zero_weights):
    rng = np.random.default_rng(seed)
    route = _route(rng, bent)
    n_t = CANDIDATES.n_steps
    scene = _scene(rng, n_hyp, n_obj, n_t, p_ped, p_absent)
    crosswalks = (Crosswalk(center=np.array([20.0, 0.0]), walk_heading_rad=0.5 * np.pi,
                            length_m=10.0, width_m=4.0),) if crosswalk else ()
    theta = rng.uniform(0.0, 3.0, 6) * (rng.random(6) < 0.6 if zero_weights else 1.0)
    polygon = np.array([[10.0, -5.0], [25.0, -5.0], [25.0, 5.0], [10.0, 5.0]])
    yield_zones = tuple((polygon + 3.0 * k, rng.random((n_hyp, n_obj)) < 0.6)
                        for k in range(zones))
    curve = CurveSpeed(route, 2.5, 2.3) if bent else None
    args = (CANDIDATES, theta, rng.uniform(5.0, 12.0), VehicleParams(), route,
            rng.uniform(0.0, 40.0), rng.uniform(0.0, 12.0), rng.uniform(-3.0, 2.0), scene,
            crosswalks)
    extra = {"yield_zones": yield_zones, "yield_margin_s": 1.5, "curve_speed": curve}
    ego, around = PlanningEgo(*args[:8]), Surroundings(*args[8:], **extra)
    reference = evaluate_candidates(ego, around, geometry=True, vehicle_gaps_only=True)
    fast = vehicle_gap_evaluation(ego, around)
    for name in FIELDS:
        want, got = getattr(reference, name), getattr(fast, name)
        assert (want is None) == (got is None), name
        if want is not None:
            assert got.shape == want.shape, name
            assert np.array_equal(got, want, equal_nan=True), name
            assert np.array_equal(np.signbit(got), np.signbit(want)), name
            assert np.array_equal(got.sum(axis=-1), want.sum(axis=-1), equal_nan=True), name


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), bent=st.booleans())
def test_pose_at_equals_point_at_and_its_heading(seed, bent):
    rng = np.random.default_rng(seed)
    route = _route(rng, bent)
    s = rng.uniform(-10.0, route.length_m + 10.0, (4, 3, 5))
    xy, heading = route.point_at(s)
    fast_xy, direction = route.pose_at(s)
    assert np.array_equal(fast_xy, xy)
    direction = np.broadcast_to(direction, xy.shape)
    assert np.array_equal(direction[..., 0], np.cos(heading))
    assert np.array_equal(direction[..., 1], np.sin(heading))


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 3), n_obj=st.integers(0, 4),
       bent=st.booleans(), crosswalk=st.booleans(), zones=st.integers(0, 2),
       p_ped=st.sampled_from([0.0, 0.5, 1.0]), stop=st.sampled_from([None, 5.0, 30.0, 80.0]),
       rules=st.booleans())
def test_kernel_rule_totals_equal_the_evaluations_totals(seed, n_hyp, n_obj, bent, crosswalk,
                                                         zones, p_ped, stop, rules):
    """kernel_rule_totals (cost_kernels.plan_totals) is rule_abiding_totals of the evaluation."""
    rng = np.random.default_rng(seed)
    route = _route(rng, bent)
    scene = _scene(rng, n_hyp, n_obj, CANDIDATES.n_steps, p_ped, 0.3)
    crosswalks = (Crosswalk(center=np.array([20.0, 0.0]), walk_heading_rad=0.5 * np.pi,
                            length_m=10.0, width_m=4.0),) if crosswalk else ()
    theta = rng.uniform(0.0, 3.0, 6) * (rng.random(6) < 0.8)
    polygon = np.array([[10.0, -5.0], [25.0, -5.0], [25.0, 5.0], [10.0, 5.0]])
    road = None
    if rules:
        road = RoadRules(stop, tuple((polygon + 3.0 * k, rng.random((n_hyp, n_obj)) < 0.6)
                                     for k in range(zones)),
                         CurveSpeed(route, 2.5, 2.3) if bent else None)
    model = DriverModel()
    s0, v0 = rng.uniform(0.0, 40.0), rng.uniform(0.0, 12.0)
    args = (CANDIDATES, theta, rng.uniform(5.0, 12.0), model.vehicle, route, s0, v0,
            rng.uniform(-3.0, 2.0), scene, crosswalks)
    extra = () if road is None else (road.yield_zones, model.yield_margin_s, road.curve_speed)
    ego, around = PlanningEgo(*args[:8]), Surroundings(*args[8:], *extra)
    ev = vehicle_gap_evaluation(ego, around)
    want = rule_abiding_totals(ev, model, s0, road)
    got = kernel_rule_totals(ego, around, *(() if road is None else (road.stop_s_m,)))
    assert got.shape == want.shape
    assert np.array_equal(got, want, equal_nan=True)
    assert np.array_equal(np.signbit(got), np.signbit(want))


@pytest.mark.filterwarnings("ignore:invalid value encountered in cast")  # nan: the reference
@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 3), n_obj=st.integers(0, 4),
       bent=st.booleans(), crosswalk=st.booleans(), zones=st.integers(0, 2),
       p_ped=st.sampled_from([0.0, 0.5, 1.0]),
       odd_speed=st.sampled_from([None, 0.0, -0.0, np.nan, 2e6]))
def test_evaluations_from_several_speeds_equal_one_evaluation_per_speed(
        seed, n_hyp, n_obj, bent, crosswalk, zones, p_ped, odd_speed):
    """vehicle_gap_evaluations shares the scene's work: each speed's result is unchanged by it.

    A speed of -0.0 among them is evaluated as 0.0; a non-finite or huge one is refused.
    """
    rng = np.random.default_rng(seed)
    route = _route(rng, bent)
    scene = _scene(rng, n_hyp, n_obj, CANDIDATES.n_steps, p_ped, 0.3)
    crosswalks = (Crosswalk(center=np.array([20.0, 0.0]), walk_heading_rad=0.5 * np.pi,
                            length_m=10.0, width_m=4.0),) if crosswalk else ()
    theta = rng.uniform(0.0, 3.0, 6)
    polygon = np.array([[10.0, -5.0], [25.0, -5.0], [25.0, 5.0], [10.0, 5.0]])
    extra = {"yield_zones": tuple((polygon + 3.0 * k, rng.random((n_hyp, n_obj)) < 0.6)
                                  for k in range(zones)),
             "yield_margin_s": 1.5, "curve_speed": CurveSpeed(route, 2.5, 2.3) if bent else None}
    speeds = list(rng.uniform(0.0, 12.0, 3)) + ([] if odd_speed is None else [odd_speed])
    head = (CANDIDATES, theta, rng.uniform(5.0, 12.0), VehicleParams(), route,
            rng.uniform(0.0, 40.0))
    tail = (rng.uniform(-3.0, 2.0), scene, crosswalks)
    around = Surroundings(*tail[1:], **extra)
    if odd_speed is not None and not abs(odd_speed) < 1e6:
        with pytest.raises(ValueError, match="initial speed"):
            vehicle_gap_evaluations(PlanningEgo(*head, np.nan, tail[0]), np.array(speeds), around)
        return
    shared = vehicle_gap_evaluations(PlanningEgo(*head, np.nan, tail[0]), np.array(speeds),
                                     around)
    assert len(shared) == len(speeds)
    for v0, got_ev in zip(speeds, shared):
        want_ev = vehicle_gap_evaluation(PlanningEgo(*head, v0, tail[0]), around)
        for name in FIELDS:
            want, got = getattr(want_ev, name), getattr(got_ev, name)
            assert (want is None) == (got is None), name
            if want is not None:
                assert np.array_equal(got, want, equal_nan=True), (name, v0)
                assert np.array_equal(np.signbit(got), np.signbit(want)), (name, v0)
