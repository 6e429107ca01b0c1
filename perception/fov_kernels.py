"""The field of view's array arithmetic around its ray queries, compiled by numba.

perception/fov.py loads this module at the first field of view of a process (numba is not
imported with `import marl_social`). Each kernel does, element by element, the same operations
in the same order as the numpy formulation it replaces (kept in tests/perception/
test_fov_kernels.py, which checks that the two agree bit for bit); the trigonometry (np.cos,
np.sin, np.arctan2) stays in numpy, whose implementations may differ from the C library's.
No fast-math (no fused multiply-adds), no threads. Compiled once, cached in __pycache__.

Shapes: n agents, K sample points per agent, S static polygons, D depth rays in all.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types

_F8 = types.float64
_I8 = types.int64
_B1 = types.boolean
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}
_PI = np.pi
_TWO_PI = 2 * np.pi  # the Python float numpy's `(b + np.pi) % (2 * np.pi)` divides by


def _array(ndim: int, dtype=_F8, layout: str = "C"):
    """The numba type of a read-only array (a writable one converts to it)."""
    return types.Array(dtype, ndim, layout, readonly=True)


@numba.njit(cache=True)
def _nan_max(a, b):
    """np.maximum(a, b) of two floats: the larger, NaN if either is NaN."""
    return a if (a > b or math.isnan(a)) else b


@numba.njit([(_array(2, layout="A"), _array(1, layout="A"), _array(1, layout="A"),
              _array(3))], **_JIT)
def sample_points(xy, cos_heading, sin_heading, local):
    """`sim.footprint.place_local` of the sample points and their offsets from every observer.

    Args:
        xy: (n, 2) agent positions [m].
        cos_heading: (n,) np.cos of the agents' headings.
        sin_heading: (n,) np.sin of the agents' headings.
        local: (n, K, 2) body-frame sample points (fov.sample_point_layout) [m].

    Returns:
        points (n, K, 2) [m] (x = (x0 + lx cos) - ly sin, y = (y0 + lx sin) + ly cos) and
        rel (n, n, K, 2) [m], rel[o, t, k] = points[t, k] - xy[o].
    """
    n, n_k = local.shape[0], local.shape[1]
    points = np.empty((n, n_k, 2))
    for t in range(n):
        c, s, x0, y0 = cos_heading[t], sin_heading[t], xy[t, 0], xy[t, 1]
        for k in range(n_k):
            lx, ly = local[t, k, 0], local[t, k, 1]
            points[t, k, 0] = x0 + lx * c - ly * s
            points[t, k, 1] = y0 + lx * s + ly * c
    rel = np.empty((n, n, n_k, 2))
    for o in range(n):
        ox, oy = xy[o, 0], xy[o, 1]
        for t in range(n):
            for k in range(n_k):
                rel[o, t, k, 0] = points[t, k, 0] - ox
                rel[o, t, k, 1] = points[t, k, 1] - oy
    return points, rel


_OBSERVERS = types.Tuple((_array(2, layout="A"), _array(1, layout="A"), _array(1),
                          _array(1, layout="A"), _array(2, _B1)))
_BOXES = types.UniTuple(_array(2), 2)
_DEPTH_RAYS = types.Tuple((_array(1), _array(1), _array(1, _I8), _array(1)))


@numba.njit([(_array(4), _array(3, layout="A"), _OBSERVERS, _BOXES, _DEPTH_RAYS)], **_JIT)
def sensed_rays(rel, arctan, observers, boxes, depth_rays):
    """Which sample points each observer could see, its target rays and its depth rays' ends.

    Args:
        rel: (n, n, K, 2) `sample_points`' offsets [m].
        arctan: (n, n, K) np.arctan2 of rel's y and x.
        observers: the n agents' (xy (n, 2) positions [m], heading (n,) [rad], range2 (n,)
            squared sensor ranges [m^2], half_angle (n,) half-angles of the view cones [rad],
            pair_ok (n, n) bool, the (observer, target) pairs that can see each other).
        boxes: the static polygons' bounding boxes (box_min (S, 2) lower corners, box_max
            (S, 2) upper corners) [m].
        depth_rays: the D depth rays' (cos_dir (D,) and sin_dir (D,) np.cos and np.sin of
            their directions, depth_observer (D,) int their observers, depth_range (D,) their
            lengths [m]).

    Returns:
        sensed (n, n, K) bool: within range ((rel_x^2 + rel_y^2) <= range2) and cone
        (|((arctan - heading) + pi) % 2 pi - pi| <= half_angle) of a pair that can see; the
        (2, m) observers and targets of the sensed centres (np.nonzero of sensed[:, :, 0]);
        static_near (n,) bool, some box within range (the gap max(max(min - xy, xy - max), 0)
        squared and summed <= range2); the depth rays' ends (D, 2) [m], (cos x range) + x.
    """
    xy, heading, range2, half_angle, pair_ok = observers
    box_min, box_max = boxes
    cos_dir, sin_dir, depth_observer, depth_range = depth_rays
    n, n_k = rel.shape[0], rel.shape[2]
    sensed = np.empty((n, n, n_k), dtype=np.bool_)
    centre_pairs = np.empty((2, n * n), dtype=np.int64)
    m = 0
    for o in range(n):
        h, r2, half = heading[o], range2[o], half_angle[o]
        for t in range(n):
            ok = pair_ok[o, t]
            for k in range(n_k):
                dx, dy = rel[o, t, k, 0], rel[o, t, k, 1]
                dist2 = dx * dx + dy * dy
                bearing = abs((arctan[o, t, k] - h + _PI) % _TWO_PI - _PI)
                sensed[o, t, k] = (dist2 <= r2) and (bearing <= half) and ok
            if sensed[o, t, 0]:
                centre_pairs[0, m] = o
                centre_pairs[1, m] = t
                m += 1
    static_near = np.zeros(n, dtype=np.bool_)
    for o in range(n):
        for j in range(box_min.shape[0]):
            gx = _nan_max(_nan_max(box_min[j, 0] - xy[o, 0], xy[o, 0] - box_max[j, 0]), 0.0)
            gy = _nan_max(_nan_max(box_min[j, 1] - xy[o, 1], xy[o, 1] - box_max[j, 1]), 0.0)
            if gx * gx + gy * gy <= range2[o]:
                static_near[o] = True
                break
    ends = np.empty((len(depth_observer), 2))
    for d in range(len(depth_observer)):
        o = depth_observer[d]
        ends[d, 0] = cos_dir[d] * depth_range[d] + xy[o, 0]
        ends[d, 1] = sin_dir[d] * depth_range[d] + xy[o, 1]
    return sensed, centre_pairs[:, :m].copy(), static_near, ends


@numba.njit([(_array(3, _B1), _array(2, _B1))], **_JIT)
def hidden_centre_points(sensed, visible):
    """The second round's rays: sensed corner points of the targets whose centre was hidden.

    Args:
        sensed: (n, n, K) bool from `sensed_rays`.
        visible: (n, n) bool after the first round.

    Returns:
        (3, m) observer, target and corner k (1..K-1) of every sensed[o, t, k] (k >= 1) with
        visible[o, t] False, in np.nonzero's order.
    """
    n, n_k = sensed.shape[0], sensed.shape[2]
    out = np.empty((3, n * n * max(n_k - 1, 0)), dtype=np.int64)
    m = 0
    for o in range(n):
        for t in range(n):
            if visible[o, t]:
                continue
            for k in range(1, n_k):
                if sensed[o, t, k]:
                    out[0, m], out[1, m], out[2, m] = o, t, k
                    m += 1
    return out[:, :m].copy()


@numba.njit([_B1[::1](_array(2), _array(2), _array(1, _I8), _array(1, _I8), _array(2, layout="A"),
                      _array(1), _array(1, _B1))], **_JIT)
def maybe_blocked(start, end, ray_observer, target, centres, radii, static_near):
    """The numpy broad phase: could anything be in the way of each ray? (R,) bool.

    True for the rays of observers with static_near (not tested). Otherwise whether the segment
    passes within radii_c of a centre c other than the ray's observer and (for the first
    len(target) rays) its target: with d = end - start, w = (-start) - (-centre),
    t = clip((w_x d_x + w_y d_y) / max(d_x^2 + d_y^2, 1e-12), 0, 1) (written as * of the
    reciprocal, as numpy computed it), (w_x - t d_x)^2 + (w_y - t d_y)^2 <= radii_c^2.

    Args:
        start: (R, 2) ray starts [m].
        end: (R, 2) ray ends [m].
        ray_observer: (R,) each ray's observer.
        target: (T,) the targets of the first T rays.
        centres: (n, 2) agent centres [m].
        radii: (n,) bounding radii, -1 for an inactive agent [m].
        static_near: (n,) bool, observers with a static polygon within range.
    """
    n_rays = start.shape[0]
    maybe = np.ones(n_rays, dtype=np.bool_)
    for r in range(n_rays):
        o = ray_observer[r]
        if static_near[o]:
            continue
        t_skip = target[r] if r < len(target) else -1
        dx = end[r, 0] - start[r, 0]
        dy = end[r, 1] - start[r, 1]
        dd = dx * dx + dy * dy
        inv_dd = 1.0 / (dd if (dd > 1e-12 or math.isnan(dd)) else 1e-12)
        hit = False
        for c in range(centres.shape[0]):
            if c == o or c == t_skip:
                continue
            wx = (-start[r, 0]) - (-centres[c, 0])
            wy = (-start[r, 1]) - (-centres[c, 1])
            t = (wx * dx + wy * dy) * inv_dd
            if not math.isnan(t):  # np.clip: NaN stays, 0.0 / 1.0 on a tie
                t = t if t > 0.0 else 0.0  # noqa: FURB136 - the tie rule spelled out
                t = t if t < 1.0 else 1.0  # noqa: FURB136
            wx -= t * dx
            wy -= t * dy
            if wx * wx + wy * wy <= radii[c] * radii[c]:
                hit = True
                break
        maybe[r] = hit
    return maybe
