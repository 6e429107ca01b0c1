"""The one cost module: features mean what their docstrings say; the weighted fast path equals
theta . phi; the scalar route projection equals the vectorized one."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.sim.costs import (
    FEATURE_NAMES,
    AgentFootprints,
    AgentMotion,
    CostWeights,
    crosswalk_occupancy,
    pairwise_step_features,
    step_cost,
    step_features,
)
from marl_social.sim.footprint import circle_layout, covering_circles, place_along
from marl_social.sim.road_map import Crosswalk, Route

CW = Crosswalk(np.array([50.0, 0.0]), np.pi / 2, 7.0, 4.0)


def _features(ego_xy, other_xy, other_is_ped, ego_is_ped=False, **kw):
    """Features of B egos (B, 2) against M others each (B, M, 2) (or (M, 2) for B = 1)."""
    ego_xy = np.atleast_2d(np.asarray(ego_xy, float))
    other_xy = np.asarray(other_xy, float)
    if other_xy.ndim == 2:
        other_xy = other_xy[None]
    b, m = other_xy.shape[:2]
    is_ped = np.broadcast_to(np.asarray(other_is_ped, bool), (b, m))
    ol, ow = np.where(is_ped, 0.6, 4.5), np.where(is_ped, 0.6, 1.8)
    el, ew = (0.6, 0.6) if ego_is_ped else (4.5, 1.8)
    ec, er = covering_circles(ego_xy, np.zeros(b), el, ew, ego_is_ped)
    oc, orad = covering_circles(other_xy, np.zeros((b, m)), ol, ow, is_ped)
    args = {
        "lateral_m": kw.get("lateral", 0.0), "speed_mps": kw.get("v", 10.0), "v_ref_mps": 12.0,
        "accel_mps2": kw.get("a", 1.0), "prev_accel_mps2": kw.get("a_prev", 0.0),
        "ego_xy": ego_xy, "ego_radius": 0.5 * np.hypot(el, ew), "ego_is_ped": ego_is_ped,
        "ego_circles": ec, "ego_circle_r": er, "other_xy": other_xy,
        "other_radius": 0.5 * np.hypot(ol, ow), "other_is_ped": is_ped,
        "other_circles": oc, "other_circle_r": orad, "other_mask": np.ones((b, m), bool),
        "crosswalks": (CW,),
    }
    return step_features(**args), args


def test_feature_values_and_units():
    phi, _ = _features([0.0, 0.0], [[30.0, 0.0]], [False], lateral=0.5, v=10.0, a=1.5,
                       a_prev=-0.5)
    f = dict(zip(FEATURE_NAMES, phi[0]))
    assert f["tracking"] == pytest.approx(0.25)
    assert f["speed"] == pytest.approx(4.0)
    assert f["accel"] == pytest.approx(2.25)
    assert f["jerk"] == pytest.approx(4.0)
    assert 0.0 < f["safety"] < np.exp(-20.0)
    assert f["crosswalk"] == pytest.approx(0.0, abs=1e-9)


def test_safety_grows_as_others_come_closer():
    far = _features([0.0, 0.0], [[20.0, 0.0]], [False])[0][0, 4]
    near = _features([0.0, 0.0], [[8.0, 0.0]], [False])[0][0, 4]
    touching = _features([0.0, 0.0], [[4.5, 0.0]], [False])[0][0, 4]
    assert far < near < touching == pytest.approx(1.0)


def test_crosswalk_conflict_needs_a_car_and_a_pedestrian_in_it_at_once():
    car_in, ped_in, ped_out = [50.0, 1.75], [50.0, -1.0], [50.0, -6.0]
    both = _features([car_in], [ped_in], [True])[0][0, 5]
    ped_on_curb = _features([car_in], [ped_out], [True])[0][0, 5]
    two_cars = _features([car_in], [[50.0, -1.75]], [False])[0][0, 5]
    car_before = _features([[40.0, 1.75]], [ped_in], [True])[0][0, 5]
    assert both == pytest.approx(1.0, abs=1e-3)
    assert ped_on_curb < 1e-6 and two_cars == 0.0 and car_before < 1e-6
    # symmetric: the pedestrian's own feature sees the car
    ped_view = _features([ped_in], [car_in], [False], ego_is_ped=True)[0][0, 5]
    assert ped_view == pytest.approx(both)


def test_occupancy_is_smooth_and_bounded():
    y = np.linspace(-8, 8, 161)
    occ = crosswalk_occupancy(np.column_stack([np.full_like(y, 50.0), y]), 0.3, CW)
    assert np.all((occ >= 0) & (occ <= 1)) and np.all(np.abs(np.diff(occ)) < 0.5)


def test_step_cost_is_theta_dot_features():
    rng = np.random.default_rng(0)
    for _ in range(20):
        theta = rng.uniform(0, 5, 6) * (rng.random(6) > 0.3)
        phi, args = _features(rng.uniform([40, -3], [60, 3], (7, 2)),
                              rng.uniform([40, -5], [60, 5], (7, 3, 2)),
                              [True, False, True])
        assert step_cost(theta, **args) == pytest.approx(phi @ theta)


def test_cost_weights_validation():
    with pytest.raises(ValueError, match="speed"):
        CostWeights(speed=-1.0)
    with pytest.raises(ValueError, match="unknown cost features"):
        CostWeights.from_any({"velocity": 1.0})
    assert CostWeights.from_any([1, 2, 3, 4, 5, 6]).crosswalk == 6.0


def test_scalar_projection_is_the_vectorized_one_bit_for_bit():
    """project_point (a Python loop on short routes) is project, on short and long routes."""
    rng = np.random.default_rng(1)
    routes = [Route([[0, 0], [10, 0], [15, 5], [15, 20]])] + [
        Route(np.cumsum(rng.normal(size=(n, 2)) * rng.uniform(0.1, 20), axis=0))
        for n in (2, 3, 5, 6, 7, 16, 17, 40) for _ in range(5)]
    for route in routes:
        lo, hi = route.points.min(axis=0) - 10.0, route.points.max(axis=0) + 10.0
        for x, y in rng.uniform(lo, hi, (100, 2)):
            s, lat, _ = route.project(np.array([x, y]))
            assert route.project_point(float(x), float(y)) == (float(s), float(lat))


def test_a_pedestrian_on_the_sidewalk_does_not_occupy_the_crosswalk():
    """Across the road only the centre counts: 0.5 m behind the curb (y = -4.0) is off."""
    on_curb = crosswalk_occupancy(np.array([50.0, -4.0]), 0.42, CW)
    on_road = crosswalk_occupancy(np.array([50.0, -3.0]), 0.42, CW)
    assert on_curb < 0.01 and on_road > 0.99
    # along the road a footprint counts as soon as it overlaps
    assert crosswalk_occupancy(np.array([47.7, 1.75]), 0.5, CW) > 0.5


@pytest.mark.parametrize("seed", range(6))
def test_pairwise_features_equal_the_generic_ones_bit_for_bit(seed):
    """The env's fast path (every agent the others' other) is step_features, exactly."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 12))
    is_ped = rng.random(n) < 0.4
    if seed == 0:
        is_ped[:] = True  # every footprint's circles coincide
    length = np.where(is_ped, 0.6, rng.uniform(3.5, 5.5, n))
    width = np.where(is_ped, 0.6, rng.uniform(1.6, 2.1, n))
    xy = rng.uniform([35.0, -10.0], [65.0, 10.0], (n, 2))
    heading = rng.uniform(-np.pi, np.pi, n)
    radius = 0.5 * np.hypot(length, width)
    along, circle_r = circle_layout(length, width, is_ped)
    circles = place_along(xy, heading, along)
    active = rng.random(n) < 0.8
    others = active[None, :] & ~np.eye(n, dtype=bool)
    scalars = {"lateral_m": rng.normal(0, 1, n), "speed_mps": rng.uniform(0, 15, n),
               "v_ref_mps": rng.uniform(5, 15, n), "accel_mps2": rng.normal(0, 2, n),
               "prev_accel_mps2": rng.normal(0, 2, n)}
    crosswalks = (CW, Crosswalk(np.array([45.0, 3.0]), 0.3, 6.0, 3.0))
    generic = step_features(
        **scalars, ego_xy=xy, ego_radius=radius, ego_is_ped=is_ped, ego_circles=circles,
        ego_circle_r=circle_r, other_xy=xy[None], other_radius=radius[None],
        other_is_ped=is_ped[None], other_circles=circles[None], other_circle_r=circle_r[None],
        other_mask=others, crosswalks=crosswalks)
    fast = pairwise_step_features(AgentMotion(**scalars),
                                  AgentFootprints(xy, radius, is_ped, circles, circle_r), others,
                                  crosswalks)
    assert generic.shape == fast.shape == (n, len(FEATURE_NAMES))
    assert generic.tobytes() == fast.tobytes()


@pytest.mark.parametrize("seed", range(6))
def test_conflict_without_a_pair_of_kinds_is_the_formula_s_zeros(seed):
    """With no car-pedestrian pair the conflict is occupancy * 0 per crosswalk: the shortcut
    gives the same zeros, the same shape, and the other features as with a pair."""
    rng = np.random.default_rng(seed)
    cws = (CW, Crosswalk(np.array([20.0, 3.0]), 0.3, 6.0, 3.0))
    ego_xy = rng.normal(size=(4, 1, 5, 2)) * 10 + [50.0, 0.0]
    other_xy = rng.normal(size=(2, 1, 1, 5, 3, 2)) * 10 + [50.0, 0.0]
    is_ped = np.zeros((2, 1, 1, 1, 3), bool)
    is_ped[0, ..., 1] = seed % 2 == 0  # a pedestrian, masked out below
    mask = ~is_ped
    args = {"lateral_m": 0.0, "speed_mps": rng.uniform(0, 9, (4, 1, 5)), "v_ref_mps": 8.0,
            "accel_mps2": 1.0, "prev_accel_mps2": 0.0, "ego_xy": ego_xy, "ego_radius": 2.4,
            "ego_is_ped": False, "ego_circles": None, "ego_circle_r": None, "other_circles": None,
            "other_circle_r": None,
            "other_xy": other_xy, "other_radius": rng.uniform(0.3, 2.5, (2, 1, 1, 1, 3)),
            "other_is_ped": is_ped, "other_mask": mask, "crosswalks": cws,
            "gap": rng.uniform(0, 5, (2, 4, 1, 5, 3))}
    phi = step_features(**args)
    pair_mask = mask & is_ped
    conflict = 0.0
    for cw in cws:  # the formula, each crosswalk's term
        occ_other = crosswalk_occupancy(other_xy, args["other_radius"], cw)
        conflict = conflict + crosswalk_occupancy(ego_xy, 2.4, cw) * np.sum(
            np.where(pair_mask, occ_other, 0.0), axis=-1)
    assert phi.shape[:-1] == conflict.shape == (2, 4, 1, 5)
    assert np.array_equal(phi[..., 5], conflict) and not np.signbit(phi[..., 5]).any()
    theta = rng.uniform(0.1, 2.0, 6)
    assert np.array_equal(step_cost(theta, **args), sum(
        w * phi[..., i] for i, w in enumerate(theta)))
