"""The per-decision fast paths equal the plain formulas they replace, bit for bit.

circle_pair_gap / scene_circles (models/circle_gaps.py) against costs.circle_gap on the covering
circles; zone_occupancy against the all-edges-at-once formula; crosswalk_occupancy against the
(..., 2) formula; Route.point_at and Route.project against the plain lookups; CurveSpeed.at
against np.clip.
"""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.models import candidates, circle_gaps
from marl_social.models.candidates import circle_pair_gap, scene_circles
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.sim.costs import (
    OCCUPANCY_SOFTNESS_M,
    circle_gap,
    crosswalk_occupancy,
    zone_occupancy,
)
from marl_social.sim.footprint import covering_circles
from marl_social.sim.road_map import Crosswalk, Route
from marl_social.sim.route_rules import CURVE_PROFILE_STEP_M, CurveSpeed


def _scene(rng, n_hyp, n_obj, n_t, all_peds=False):
    is_ped = np.ones((n_hyp, n_obj), bool) if all_peds else rng.random((n_hyp, n_obj)) < 0.5
    length = np.where(is_ped, 0.6, rng.uniform(3.5, 5.5, (n_hyp, n_obj)))
    width = np.where(is_ped, 0.6, rng.uniform(1.6, 2.2, (n_hyp, n_obj)))
    return ScenePrediction(rng.normal(size=(n_hyp, n_obj, n_t, 2)) * 8.0,
                           rng.uniform(-4, 4, (n_hyp, n_obj, n_t)), length, width,
                           0.5 * np.hypot(length, width), is_ped, np.ones((n_hyp, n_obj), bool))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 3), n_obj=st.integers(0, 4),
       all_peds=st.booleans(), ego_ped=st.booleans())
def test_circle_pair_gap_equals_circle_gap(seed, n_hyp, n_obj, all_peds, ego_ped):
    rng = np.random.default_rng(seed)
    n_t = 7
    scene = _scene(rng, n_hyp, n_obj, n_t, all_peds)
    xy, heading = rng.normal(size=(4, 5, n_t, 2)) * 8.0, rng.uniform(-4, 4, (4, 5, n_t))
    size = 0.6 if ego_ped else 4.6, 0.6 if ego_ped else 1.9
    ego_c, ego_r = covering_circles(xy, heading, *size, ego_ped)
    oc, orad = covering_circles(scene.xy, scene.heading, scene.length_m[..., None],
                                scene.width_m[..., None], scene.is_pedestrian[..., None])
    to_cand = lambda a: np.moveaxis(a, 1, 2)[:, None, None]
    reference = circle_gap(ego_c, ego_r, to_cand(oc), to_cand(orad), clip=False)
    ox, oy, other_r = scene_circles(scene)
    fast = circle_pair_gap(np.moveaxis(ego_c[..., 0], -1, 0), np.moveaxis(ego_c[..., 1], -1, 0),
                           float(ego_r.flat[0]), ox, oy, other_r)
    assert fast.shape == reference.shape == (n_hyp, 4, 5, n_t, n_obj)
    assert np.array_equal(fast, reference)


def _scene_with_extra(rng, n_hyp, n_obj, n_t):
    """A scene as the planners build it: n_obj tracked objects shared by n_hyp hypotheses,
    each hypothesis with its own extra object (a pedestrian or a car; masked out in the first)."""
    others = _scene(rng, 1, n_obj, n_t)
    is_ped = rng.random(n_hyp) < 0.5
    mask = np.ones(n_hyp, bool)
    mask[0] = False
    return others.with_extra(rng.normal(size=(n_hyp, n_t, 2)) * 8.0,
                             rng.uniform(-4, 4, (n_hyp, n_t)), np.where(is_ped, 0.6, 4.6),
                             np.where(is_ped, 0.6, 1.9), is_ped, mask)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(2, 5), n_obj=st.integers(0, 4))
def test_shared_objects_are_computed_once_with_the_same_values(seed, n_hyp, n_obj):
    """circle_pair_gap computes the objects every hypothesis shares once: the same values, bit
    for bit, as every object in every hypothesis."""
    rng = np.random.default_rng(seed)
    n_t = 6
    scene = _scene_with_extra(rng, n_hyp, n_obj, n_t)
    ego_x, ego_y = rng.normal(size=(2, 3, 4, 5, n_t)) * 8.0
    ox, oy, other_r = scene_circles(scene)
    fast = circle_pair_gap(ego_x, ego_y, 1.1, ox, oy, other_r)
    full = circle_gaps._circle_pair_gap(ego_x, ego_y, 1.1, ox, oy, other_r)
    assert fast.shape == full.shape == (n_hyp, 4, 5, n_t, n_obj + 1)
    assert np.array_equal(fast, full)


def _zone_claims_reference(scene, polygon, priority, margin_s, dt_s):
    """zone_claims as first written: every object of every hypothesis, then masked."""
    velocity = np.gradient(scene.xy, dt_s, axis=2)
    offsets = np.arange(round(margin_s / dt_s) + 1) * dt_s
    ahead = scene.xy[None] + offsets[:, None, None, None, None] * velocity[None]
    circles, radii = covering_circles(ahead, scene.heading[None], scene.length_m[None, ..., None],
                                      scene.width_m[None, ..., None],
                                      scene.is_pedestrian[None, ..., None])
    claim = zone_occupancy(circles, radii, polygon).max(axis=0)
    return np.where((priority & scene.mask)[..., None], claim, 0.0)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 5), n_obj=st.integers(0, 4),
       p_priority=st.sampled_from([0.0, 0.3, 1.0]))
def test_zone_claims_of_the_claimants_only_equal_all_then_masked(seed, n_hyp, n_obj,
                                                                 p_priority):
    """zone_claims computes only the present priority objects: the same values, bit for bit."""
    rng = np.random.default_rng(seed)
    scene = _scene_with_extra(rng, n_hyp, n_obj, 12)
    polygon = np.array([[-4.0, -4.0], [4.0, -4.0], [4.0, 4.0], [-4.0, 4.0]]) * 2.0
    priority = rng.random((n_hyp, n_obj + 1)) < p_priority
    claims = candidates.zone_claims(scene, polygon, priority, 1.5, 0.25)
    assert np.array_equal(claims, _zone_claims_reference(scene, polygon, priority, 1.5, 0.25))


def _zone_occupancy_reference(circles, circle_r, polygon):
    poly = np.asarray(polygon, dtype=np.float64)
    edge = np.roll(poly, -1, axis=0) - poly
    length = np.linalg.norm(edge, axis=1)
    rel = np.asarray(circles)[..., None, :] - poly
    inside = ((edge[:, 0] * rel[..., 1] - edge[:, 1] * rel[..., 0]) / length).min(axis=-1)
    depth = (inside + circle_r).max(axis=-1)
    return 0.5 * (1.0 + np.tanh(0.5 * depth / 0.1))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_vertices=st.integers(3, 8))
def test_zone_occupancy_equals_all_edges_at_once(seed, n_vertices):
    rng = np.random.default_rng(seed)
    angles = np.linspace(0, 2 * np.pi, n_vertices, endpoint=False) + rng.uniform(0, 2 * np.pi)
    polygon = np.column_stack([np.cos(angles), np.sin(angles)]) * rng.uniform(2, 10) + 3.0
    circles = rng.normal(size=(6, 5, 3, 2)) * 6.0 + 3.0
    radius = rng.uniform(0.3, 1.5, (6, 5, 3))
    assert np.array_equal(zone_occupancy(circles, radius, polygon),
                          _zone_occupancy_reference(circles, radius, polygon))


def _point_at_reference(route, s):
    s = np.asarray(s, dtype=np.float64)
    k = np.clip(np.searchsorted(route.vertex_s_m, s, side="right") - 1, 0,
                len(route.segment_length_m) - 1)
    xy = (route.segment_start_m[k]
          + (s - route.vertex_s_m[k])[..., None] * route.segment_direction[k])
    return xy, route.segment_heading_rad[k]


def _project_reference(route, xy):
    xy = np.asarray(xy, dtype=np.float64)
    rel = xy[..., None, :] - route.segment_start_m
    t = np.clip(np.einsum("...sk,sk->...s", rel, route.segment_direction), 0.0,
                route.segment_length_m)
    closest = route.segment_start_m + t[..., None] * route.segment_direction
    k = np.argmin(np.sum((xy[..., None, :] - closest) ** 2, axis=-1), axis=-1)
    t_k = np.take_along_axis(t, k[..., None], axis=-1)[..., 0]
    rel_k = np.take_along_axis(rel, k[..., None, None], axis=-2)[..., 0, :]
    dir_k = route.segment_direction[k]
    lateral = dir_k[..., 0] * rel_k[..., 1] - dir_k[..., 1] * rel_k[..., 0]
    return route.vertex_s_m[k] + t_k, lateral, route.segment_heading_rad[k]


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_points=st.integers(2, 12))
def test_route_lookups_equal_the_plain_formulas(seed, n_points):
    rng = np.random.default_rng(seed)
    route = Route(np.cumsum(rng.uniform(1.0, 6.0, (n_points, 2)), axis=0))
    for s in (rng.uniform(-5, route.length_m + 5, (4, 3, 5)), float(rng.uniform(0, 9)),
              np.array(route.length_m + 2.0)):
        fast, reference = route.point_at(s), _point_at_reference(route, s)
        for a, b in zip(fast, reference):
            assert np.array_equal(a, b) and type(a) is type(b) and np.shape(a) == np.shape(b)
    for xy in (rng.normal(size=2) * 20, rng.normal(size=(6, 2)) * 20,
               rng.normal(size=(2, 3, 2)) * 20):
        for a, b in zip(route.project(xy), _project_reference(route, xy)):
            assert np.array_equal(a, b) and type(a) is type(b)
    # the vertices themselves (ties between two segments) and x, y given apart
    xy = np.concatenate([rng.normal(size=(7, 2)) * 20, route.points])
    reference = _project_reference(route, xy)
    for a, b in zip(route.project_xy(xy[:, 0], xy[:, 1]), reference[:2]):
        assert np.array_equal(a, b)
    for a, b in zip(route.project(xy), reference):
        assert np.array_equal(a, b)


def test_curve_speed_lookup_equals_clip():
    route = Route(np.column_stack([np.linspace(0, 30, 31), 0.02 * np.linspace(0, 30, 31) ** 2]))
    curve = CurveSpeed(route, 2.5, 2.0)
    s = np.linspace(-10, route.length_m + 10, 500)
    k = np.clip(np.rint(s / CURVE_PROFILE_STEP_M).astype(np.int64), 0, len(curve.v_max_mps) - 1)
    assert np.array_equal(curve.at(s), curve.v_max_mps[k])


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_hyp=st.integers(1, 4), n_obj=st.integers(0, 3),
       one_row=st.booleans())
def test_with_extra_equals_concatenating_the_repeated_rows(seed, n_hyp, n_obj, one_row):
    """ScenePrediction.with_extra: the scene's rows repeated (or its L rows) and the extra
    object appended, the same arrays and dtypes as np.concatenate of the broadcast rows."""
    rng = np.random.default_rng(seed)
    scene = _scene(rng, 1 if one_row else n_hyp, n_obj, 5)
    is_ped = rng.random(n_hyp) < 0.5
    extra = (rng.normal(size=(n_hyp, 5, 2)), rng.normal(size=(n_hyp, 5)),
             rng.uniform(0.5, 5.0, n_hyp), rng.uniform(0.5, 2.0, n_hyp), is_ped,
             rng.random(n_hyp) < 0.7)
    out = scene.with_extra(*extra)
    radius = 0.5 * np.hypot(extra[2], extra[3])
    for mine, add, got in zip((scene.xy, scene.heading, scene.length_m, scene.width_m,
                               scene.radius_m, scene.is_pedestrian, scene.mask),
                              (*extra[:4], radius, *extra[4:]),
                              (out.xy, out.heading, out.length_m, out.width_m, out.radius_m,
                               out.is_pedestrian, out.mask)):
        grown = np.broadcast_to(mine, (n_hyp,) + mine.shape[1:])
        reference = np.concatenate([grown, np.asarray(add)[:, None]], axis=1)
        assert got.dtype == reference.dtype and np.array_equal(got, reference)


def _crosswalk_occupancy_reference(xy, radius, cw):
    rel = np.asarray(xy, dtype=np.float64) - cw.center
    c, s = np.cos(cw.walk_heading_rad), np.sin(cw.walk_heading_rad)
    u = rel[..., 0] * c + rel[..., 1] * s
    w = -rel[..., 0] * s + rel[..., 1] * c
    depth = np.minimum(0.5 * cw.length_m - np.abs(u), 0.5 * cw.width_m - np.abs(w) + radius)
    return 0.5 * (1.0 + np.tanh(0.5 * depth / OCCUPANCY_SOFTNESS_M))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), heading=st.sampled_from([0.0, np.pi / 2, -np.pi, 0.7]))
def test_crosswalk_occupancy_equals_the_plain_formula(seed, heading):
    """Bit for bit, for every radius shape (scalar, the points' shape, broadcasting wider)."""
    rng = np.random.default_rng(seed)
    cw = Crosswalk(center=rng.normal(size=2) * 5, walk_heading_rad=heading, length_m=7.0,
                   width_m=4.0)
    xy = rng.normal(size=(3, 4, 6, 2)) * 6 + cw.center  # the in-place path (>= 128 values)
    for radius in (2.5, rng.uniform(0, 3, (3, 4, 6)), rng.uniform(0, 3, (3, 1, 6)),
                   rng.uniform(0, 3, (2, 3, 4, 6))):
        occ, ref = crosswalk_occupancy(xy, radius, cw), _crosswalk_occupancy_reference(xy, radius, cw)
        assert occ.shape == ref.shape and np.array_equal(occ, ref)
    for one in (xy[0, 0, 0], xy[0, 0]):  # one point, a row of points
        occ, ref = crosswalk_occupancy(one, 0.4, cw), _crosswalk_occupancy_reference(one, 0.4, cw)
        assert np.array_equal(occ, ref) and type(occ) is type(ref)


def test_scene_crosswalk_occupancy_is_remembered_only_for_a_read_only_scene():
    """The others' occupancy the candidates use: crosswalk_occupancy of the scene's predictions;
    kept for a scene nobody can write to, recomputed for one that can change."""
    rng = np.random.default_rng(3)
    cws = (Crosswalk(center=np.array([1.0, 0.5]), walk_heading_rad=np.pi / 2, length_m=7.0,
                     width_m=4.0),)
    scene = _scene(rng, 3, 4, 12, all_peds=True)
    expected = crosswalk_occupancy(scene.xy.swapaxes(1, 2)[:, None, None],
                                   scene.radius_m[:, None, None, None, :], cws[0])
    (occ,) = circle_gaps.scene_crosswalk_occupancy(scene, cws)
    assert occ.shape == (3, 1, 1, 12, 4) and np.array_equal(occ, expected)
    scene.xy[...] += 1.0  # writable: not remembered
    (moved,) = circle_gaps.scene_crosswalk_occupancy(scene, cws)
    assert np.array_equal(moved, crosswalk_occupancy(scene.xy.swapaxes(1, 2)[:, None, None],
                                                     scene.radius_m[:, None, None, None, :],
                                                     cws[0]))
    for array in (scene.xy, scene.radius_m):
        array.setflags(write=False)
    first = circle_gaps.scene_crosswalk_occupancy(scene, cws)
    assert circle_gaps.scene_crosswalk_occupancy(scene, cws) is first
    assert np.array_equal(first[0], moved) and not first[0].flags.writeable
