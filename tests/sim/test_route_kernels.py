"""Route projection's compiled kernel (sim/route_kernels.py) against numpy, bit for bit.

The numpy arithmetic it replaced in Route._project (routes of several segments) is written out
here as it stood; random routes of 2-60 segments and points over a wide range of magnitudes,
+-0, +-inf and NaN, in the shapes the planners use ((), (P,), (W, N)).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.sim.road_map import Route, RouteSet
from tests.helpers import same_bits
from tests.reference.lane_test import on_lanes as numpy_on_lanes

SEEDS = st.integers(0, 2**32 - 1)


def _reference_project(route: Route, x: np.ndarray, y: np.ndarray):
    """Route._project on a route of several segments as it stood in numpy."""
    sx, sy, dx, dy, length = route._sx, route._sy, route._dx, route._dy, route.segment_length_m
    rel_x = x[..., None] - sx  # (..., S)
    rel_y = y[..., None] - sy
    t = rel_x * dx + rel_y * dy
    t = np.minimum(np.maximum(t, 0.0), length)
    n_seg = len(length)
    ex = x[..., None] - (sx + t * dx)
    ey = y[..., None] - (sy + t * dy)
    k = np.argmin(ex ** 2 + ey ** 2, axis=-1)
    k = np.asarray(k)
    flat = k.ravel() + n_seg * np.arange(k.size)
    t_k, rx, ry = (a.ravel()[flat].reshape(k.shape) for a in (t, rel_x, rel_y))
    dx_k, dy_k = dx[k], dy[k]
    s = route.vertex_s_m[k] + t_k
    return np.asarray(s), np.asarray(dx_k * ry - dy_k * rx), k


def _route(rng: np.random.Generator) -> Route:
    """A random polyline: 2-60 segments, lengths from millimetres to hundreds of metres."""
    n = int(rng.integers(2, 61))
    steps = rng.normal(size=(n, 2)) * 10.0 ** rng.uniform(-2, 2.5, size=(n, 1))
    if rng.random() < 0.3:  # a smooth curve, as the maps' lanes
        angle = np.cumsum(rng.normal(0.0, 0.1, n))
        steps = np.column_stack([np.cos(angle), np.sin(angle)]) * rng.uniform(0.5, 5.0)
    steps[np.linalg.norm(steps, axis=1) <= 1e-6] = 1.0
    return Route(np.vstack([rng.normal(size=2) * 50.0, steps]).cumsum(axis=0))


def _points(rng: np.random.Generator, route: Route, shape: tuple) -> np.ndarray:
    """(shape + (2,)) points near the route, far from it, on its vertices, and special values."""
    n = int(np.prod(shape, dtype=int))
    base = route.points[rng.integers(0, len(route.points), n)]
    xy = base + rng.normal(size=(n, 2)) * 10.0 ** rng.uniform(-6, 3, size=(n, 1))
    pick = rng.random(n)
    xy[pick < 0.1] = base[pick < 0.1]  # exactly on a vertex (ties between segments)
    special = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 1e300, -1e-300])
    odd = rng.random((n, 2)) < 0.05
    xy[odd] = rng.choice(special, int(odd.sum()))
    return xy.reshape(shape + (2,))


@settings(max_examples=200, deadline=None)
@given(SEEDS, st.sampled_from([(), (1,), (7,), (5, 24), (3, 4, 6)]))
def test_projection_on_several_segments_matches_numpy_bit_for_bit(seed, shape):
    rng = np.random.default_rng(seed)
    route = _route(rng)
    xy = _points(rng, route, shape)
    x, y = xy[..., 0], xy[..., 1]
    with np.errstate(invalid="ignore", over="ignore"):
        expected = _reference_project(route, x, y)
        got = route._project(x, y)
    assert all(same_bits(g, e) for g, e in zip(got, expected))


def test_project_xy_and_project_use_the_kernel_on_strided_inputs():
    rng = np.random.default_rng(3)
    route = _route(rng)
    xy = _points(rng, route, (6, 9))
    xy[np.isnan(xy)] = 0.0
    s, lateral = route.project_xy(xy[..., 0], xy[..., 1])  # strided views
    with np.errstate(invalid="ignore", over="ignore"):
        ref_s, ref_lateral, ref_k = _reference_project(route, xy[..., 0], xy[..., 1])
    assert same_bits(s, ref_s) and same_bits(lateral, ref_lateral)
    s1, lat1, heading1 = route.project(xy[2, 3])
    assert np.isscalar(s1) or np.ndim(s1) == 0
    assert s1 == ref_s[2, 3] and lat1 == ref_lateral[2, 3]
    assert heading1 == route.segment_heading_rad[ref_k[2, 3]]


def _reference_route_set_project(routes: RouteSet, xy: np.ndarray):
    """RouteSet.project as it stood in numpy."""
    rel = xy[:, None, :] - routes.seg_start  # (n, S, 2)
    t = np.minimum(np.maximum(np.einsum("nsk,nsk->ns", rel, routes.seg_dir), 0.0),
                   routes.seg_len)
    closest = routes.seg_start + t[..., None] * routes.seg_dir
    d2 = ((xy[:, None, :] - closest) ** 2).sum(axis=-1)
    if not routes.valid.all():
        d2 = np.where(routes.valid, d2, np.inf)
    k = d2.argmin(axis=1)
    rows = np.arange(len(xy))
    rel_k, dir_k = rel[rows, k], routes.seg_dir[rows, k]
    lateral = dir_k[:, 0] * rel_k[:, 1] - dir_k[:, 1] * rel_k[:, 0]
    return routes.cum_s[rows, k] + t[rows, k], lateral


@settings(max_examples=200, deadline=None)
@given(SEEDS, st.integers(1, 8))
def test_route_set_projection_matches_numpy_bit_for_bit(seed, n):
    rng = np.random.default_rng(seed)
    routes = [_route(rng) if rng.random() < 0.7 else Route([[0.0, 0.0], [30.0, 1.0]])
              for _ in range(n)]
    route_set = RouteSet(routes)
    state = np.zeros((n, 4))  # the world's state table: the positions are a strided view
    state[:, :2] = [_points(rng, r, ()) for r in routes]
    with np.errstate(invalid="ignore", over="ignore"):
        expected = _reference_route_set_project(route_set, state[:, :2])
        got = route_set.project(state[:, :2])
    assert all(same_bits(g, e) for g, e in zip(got, expected))


def test_route_set_projection_wants_one_position_per_route():
    route_set = RouteSet([Route([[0.0, 0.0], [10.0, 0.0]])] * 3)
    with pytest.raises(ValueError, match=r"RouteSet.project: xy must have shape \(3, 2\)"):
        route_set.project(np.zeros((2, 2)))


def _lane(rng: np.random.Generator):
    """A random lane: a straight (one segment) or bent centreline, 2-6 m wide."""
    from marl_social.sim.road_map import Lane

    if rng.random() < 0.4:
        start = rng.normal(size=2) * 30.0
        points = np.vstack([start, start + rng.normal(size=2) * 20.0])
    else:
        points = _route(rng).points[: int(rng.integers(2, 12))]
    return Lane(points, float(rng.uniform(2.0, 6.0)))


@settings(max_examples=200, deadline=None)
@given(SEEDS, st.integers(1, 4), st.integers(0, 9))
def test_on_lanes_matches_numpy_bit_for_bit(seed, n_lanes, n_objects):
    """Objects on and off random lanes (along them, against them, across them, at their ends,
    with special values): the compiled lane test gives the numpy one's answer."""
    from marl_social.sim import route_rules

    rng = np.random.default_rng(seed)
    lanes = [_lane(rng) for _ in range(n_lanes)]
    routes = route_rules._lane_routes(tuple(lanes))
    xy = np.zeros((n_objects, 2))
    heading = rng.uniform(-4.0, 4.0, n_objects)
    for i in range(n_objects):  # near a lane, heading along it give or take
        route = routes[rng.integers(n_lanes)]
        s = rng.uniform(-2.0, route.length_m + 2.0)
        point, along = route.point_at(np.array([s]))
        xy[i] = point[0] + rng.normal(size=2) * rng.choice([0.1, 1.0, 5.0])
        if rng.random() < 0.7:
            heading[i] = along[0] + rng.normal(0.0, 0.7) + rng.choice([0.0, 2 * np.pi, np.pi])
    special = np.array([0.0, -0.0, np.inf, -np.inf, np.nan])
    odd = rng.random((n_objects, 3)) < 0.05
    xy[odd[:, :2]] = rng.choice(special, int(odd[:, :2].sum()))
    heading[odd[:, 2]] = rng.choice(special, int(odd[:, 2].sum()))
    with np.errstate(invalid="ignore", over="ignore"):
        want = numpy_on_lanes(tuple(lanes), xy, heading)
        got = route_rules.on_lanes(lanes, xy, heading)
    assert got.dtype == bool and np.array_equal(got, want)


def _reference_footprint_extent(route: Route, xy: np.ndarray, heading: np.ndarray,
                           length_m: np.ndarray, width_m: np.ndarray) -> np.ndarray:
    """The numpy corners, projection and extents that sim/route_kernels.project_footprints
    replaced in agents/robot/corridor.objects_on_path, as they stood.

    Args:
        route: the route.
        xy: (P, N, 2) rectangle centres [m].
        heading: (P, N) their headings [rad].
        length_m: (P, 1) lengths [m].
        width_m: (P, 1) widths [m].

    Returns:
        (5, P, N): the corners' smallest and largest arc length, smallest and largest lateral
        offset, |their mean lateral offset| [m]. The corners: front left, front right, rear
        right, rear left.
    """
    half_l, half_w = 0.5 * length_m, 0.5 * width_m
    c, s = np.cos(heading), np.sin(heading)
    lc, ls, wc, ws = half_l * c, half_l * s, half_w * c, half_w * s
    dx = np.empty((4,) + heading.shape)
    dy = np.empty((4,) + heading.shape)
    dx[0], dx[1], dx[2], dx[3] = lc - ws, lc + ws, ws - lc, -lc - ws
    dy[0], dy[1], dy[2], dy[3] = ls + wc, ls - wc, -ls - wc, wc - ls
    arc, lateral = route.project_xy(xy[..., 0] + dx, xy[..., 1] + dy)  # (4, P, N)
    centre = np.abs((((lateral[0] + lateral[1]) + lateral[2]) + lateral[3]) / 4.0)
    return np.stack([arc.min(axis=0), arc.max(axis=0), lateral.min(axis=0),
                     lateral.max(axis=0), centre])


@settings(max_examples=100, deadline=None)
@given(SEEDS, st.booleans(), st.sampled_from([(1, 1), (3, 24), (13, 24)]))
def test_footprint_extents_match_numpy_bit_for_bit(seed, straight, shape):
    """route_kernels.project_footprints (the robot's corridor) equals the numpy it replaced
    bit for bit, signed zeros included, on a straight (one segment) or bent route, rectangles
    near and on it at any heading."""
    from marl_social.sim.kernel_cache import route_kernels

    rng = np.random.default_rng(seed)
    route = Route([[-50.0, 1.75], [150.0, 1.75]]) if straight else _route(rng)
    xy = _points(rng, route, shape)
    xy[~np.isfinite(xy)] = 0.0
    heading = rng.uniform(-4.0, 4.0, size=shape)
    heading[rng.random(shape) < 0.2] = 0.0
    length = rng.uniform(0.3, 6.0, size=(shape[0], 1))
    width = rng.uniform(0.3, 2.5, size=(shape[0], 1))
    # the rectangles as objects of hypotheses, gathered from them in a shuffled order
    n_hyp = 3
    hyp = rng.integers(0, n_hyp, shape[0])
    obj = rng.permutation(shape[0])
    scene_xy = rng.normal(size=(n_hyp, shape[0]) + shape[1:] + (2,))
    scene_length, scene_width = rng.uniform(size=(2, n_hyp, shape[0]))
    scene_xy[hyp, obj] = xy
    scene_length[hyp, obj], scene_width[hyp, obj] = length[:, 0], width[:, 0]
    # (2, >= P): columns past the P pairs are not read
    source = np.hstack([np.vstack([hyp, obj]), np.full((2, 2), 10**6)]).astype(np.int64)
    with np.errstate(invalid="ignore", over="ignore"):
        expected = _reference_footprint_extent(route, xy, heading, length, width)
        got = np.empty((5,) + shape)
        route_kernels().project_footprints(scene_xy, np.cos(heading), np.sin(heading),
                                           scene_length, scene_width, source,
                                           route.kernel_segment_table, got)
    assert same_bits(got, expected)


@pytest.mark.parametrize("n_objects", [0, 1, 3])
def test_on_lanes_without_lanes_or_with_one_heading_for_all(n_objects):
    """No lane: no object is on one; one heading for every object: numpy's broadcast."""
    from marl_social.sim import route_rules

    rng = np.random.default_rng(n_objects)
    lanes = [_lane(rng) for _ in range(2)]
    route = route_rules._lane_routes(tuple(lanes))[0]
    point, along = route.point_at(np.full(n_objects, 0.5 * route.length_m))
    xy = point + rng.normal(size=(n_objects, 2)) * 0.1
    lane_heading = float(along[0]) if n_objects else 0.0
    for heading in (lane_heading, np.array([lane_heading + np.pi])):
        want = numpy_on_lanes(tuple(lanes), xy, heading)
        assert np.array_equal(route_rules.on_lanes(lanes, xy, heading), want)
        assert not route_rules.on_lanes([], xy, heading).any()
    if n_objects == 3:
        with pytest.raises(ValueError):
            route_rules.on_lanes(lanes, xy, np.zeros(2))
