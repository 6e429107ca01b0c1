"""One cost feature set for every agent (paper eq. 13): c = theta^T phi(x, I, u_R, u_H).

The env's rewards, the human and pedestrian planners, the robot's model of the humans, the
robot's MPC and IRL all use this module. Every function is vectorized over arbitrary leading
batch dimensions (candidates, time steps, agents).

Features per step (units):
  tracking   lateral offset from the agent's route, squared [m^2]
  speed      (v - v_ref)^2, v_ref = v_traffic or the agent's desired speed [m^2/s^2]
  accel      a^2 [m^2/s^4]
  jerk       (a_k - a_{k-1})^2, change of acceleration over one step [m^2/s^4]
  safety     sum_i exp(-d_i), d_i = gap to other agent i between covering circles [m], >= 0
  crosswalk  the right-of-way conflict [-]: sum over crosswalks of occupancy(ego) * sum over
             agents of the other kind of occupancy(other) (a vehicle and a pedestrian in the
             same crosswalk at once), plus sum over the conflict zones the ego yields at of
             occupancy(ego) * sum over the agents with the right of way there of their claim
             on the zone (`yield_zones`: their occupancy now or within the ego's time margin;
             e.g. a left-turner and oncoming traffic in the lane it crosses). The name stays
             "crosswalk" so that stored weights keep their meaning.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from marl_social.sim.kernel_cache import feature_kernels
from marl_social.sim.road_map import Crosswalk

FEATURE_NAMES = ("tracking", "speed", "accel", "jerk", "safety", "crosswalk")
N_FEATURES = len(FEATURE_NAMES)
OCCUPANCY_SOFTNESS_M = 0.1  # logistic length scale of crosswalk occupancy [m]


@dataclass(frozen=True)
class CostWeights:
    """Linear weights theta (one per feature, see FEATURE_NAMES); all must be finite, >= 0."""

    tracking: float = 1.0
    speed: float = 1.0
    accel: float = 0.1
    jerk: float = 0.1
    safety: float = 1.0
    crosswalk: float = 1000.0

    def __post_init__(self):
        for name in FEATURE_NAMES:
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"cost weight {name!r} must be finite and >= 0, got {value}")

    def as_array(self) -> np.ndarray:
        """(N_FEATURES,) in FEATURE_NAMES order."""
        return np.array([getattr(self, n) for n in FEATURE_NAMES], dtype=np.float64)

    @classmethod
    def from_any(cls, value) -> CostWeights:
        """Accept a CostWeights, a mapping of feature names, or a length-6 sequence."""
        if isinstance(value, cls):
            return value
        if isinstance(value, dict):
            unknown = set(value) - set(FEATURE_NAMES)
            if unknown:
                raise ValueError(f"unknown cost features {sorted(unknown)}; "
                                 f"known: {list(FEATURE_NAMES)}")
            return cls(**{k: float(v) for k, v in value.items()})
        arr = np.asarray(value, dtype=np.float64)
        if arr.shape != (N_FEATURES,):
            raise ValueError(f"cost weights: expected {N_FEATURES} values, got shape {arr.shape}")
        return cls(*arr.tolist())


@functools.lru_cache(maxsize=256)
def _cos_sin(angle_rad: float) -> tuple:
    """(np.cos(angle), np.sin(angle)) of a crosswalk's walk heading, computed once per angle."""
    return np.cos(angle_rad), np.sin(angle_rad)


def crosswalk_occupancy(xy, bounding_radius_m, crosswalk: Crosswalk) -> np.ndarray:
    """Smooth 0..1 indicator that a footprint is in the crosswalk rectangle.

    Along the road (across the walking direction) the footprint counts as soon as it overlaps
    the rectangle (its bounding radius is added); across the road (along the walking direction,
    curb to curb) only its centre counts: a pedestrian standing on the sidewalk next to the
    curb is not on the crosswalk, however close (occupancy < 0.01 from 0.5 m behind the curb).
    A car on the road is inside the curbs anyway.

    Args:
        xy: (..., 2) footprint centre [m]; may be a marl_social.agents.irl.jets.Jet
            (derivatives along a path).
        bounding_radius_m: (...) footprint bounding radius [m].
        crosswalk: the crosswalk rectangle.

    Returns:
        (...) occupancy in 0..1.
    """
    xy = xy if getattr(xy, "is_jet", False) else np.asarray(xy, dtype=np.float64)
    c, s = _cos_sin(crosswalk.walk_heading_rad)
    if isinstance(xy, np.ndarray) and xy.size >= _IN_PLACE_MIN_SIZE:
        return _array_occupancy(xy, bounding_radius_m, crosswalk, c, s)
    rel = xy - crosswalk.center
    u = rel[..., 0] * c + rel[..., 1] * s
    w = -rel[..., 0] * s + rel[..., 1] * c
    depth = np.minimum(
        0.5 * crosswalk.length_m - np.abs(u), 0.5 * crosswalk.width_m - np.abs(w) + bounding_radius_m
    )
    return 0.5 * (1.0 + np.tanh(0.5 * depth / OCCUPANCY_SOFTNESS_M))


_IN_PLACE_MIN_SIZE = 128  # (..., 2) arrays this large take _array_occupancy (smaller: fewer calls)


def _array_occupancy(xy: np.ndarray, bounding_radius_m, crosswalk: Crosswalk, c, s
                     ) -> np.ndarray:
    """crosswalk_occupancy of an (..., 2) array, bit for bit, with x and y apart and in place.

    The same operations on each element (u = rx c + ry s, w = ry c - rx s is -rx s + ry c
    exactly), without the (..., 2) temporaries.
    """
    rx = xy[..., 0] - crosswalk.center[0]  # (...)
    ry = xy[..., 1] - crosswalk.center[1]
    u = rx * c
    w = ry * c
    rx *= s
    ry *= s
    u += ry
    w -= rx
    np.abs(u, out=u)
    np.subtract(0.5 * crosswalk.length_m, u, out=u)
    np.abs(w, out=w)
    np.subtract(0.5 * crosswalk.width_m, w, out=w)
    if np.shape(bounding_radius_m) == () or np.broadcast_shapes(
            w.shape, np.shape(bounding_radius_m)) == w.shape:
        w += bounding_radius_m
        depth = np.minimum(u, w, out=u)
    else:
        depth = np.minimum(u, w + bounding_radius_m)
    depth *= 0.5
    depth /= OCCUPANCY_SOFTNESS_M
    np.tanh(depth, out=depth)
    depth += 1.0
    depth *= 0.5
    return depth


def zone_occupancy(circles, circle_r, polygon) -> np.ndarray:
    """Smooth 0..1 indicator that a footprint's covering circles overlap a convex zone.

    The overlap depth of a circle is its centre's signed distance inside the polygon (the
    smallest over its edges; outside near a corner this underestimates the distance, so the
    zone counts as slightly larger there) plus its radius; the footprint's is the largest over
    its circles.

    Args:
        circles: (..., C, 2) centres of the covering circles [m] (footprint.covering_circles).
        circle_r: (..., C) their radii [m].
        polygon: (V, 2) the zone's convex outline, counter-clockwise [m].

    Returns:
        (...) occupancy in 0..1.
    """
    circles = np.asarray(circles)
    x, y = circles[..., 0], circles[..., 1]  # (..., C)
    # the signed distance inside each edge, one edge at a time (V is a handful): no
    # (..., C, V, 2) array and no reduction over a tiny trailing axis
    inside = None
    for px, py, ex, ey, edge_length in _polygon_edges(polygon):
        d = (ex * (y - py) - ey * (x - px)) / edge_length
        inside = d if inside is None else np.minimum(inside, d)
    depth = (inside + circle_r).max(axis=-1)
    return 0.5 * (1.0 + np.tanh(0.5 * depth / OCCUPANCY_SOFTNESS_M))


def _polygon_edges(polygon) -> tuple:
    """((x, y, edge x, edge y, edge length), ...) per vertex of a polygon [m], cached."""
    poly = np.ascontiguousarray(polygon, dtype=np.float64)
    return _cached_polygon_edges(poly.tobytes(), poly.shape)


@functools.lru_cache(maxsize=256)
def _cached_polygon_edges(points: bytes, shape: tuple) -> tuple:
    poly = np.frombuffer(points, dtype=np.float64).reshape(shape)
    edge = np.roll(poly, -1, axis=0) - poly  # (V, 2)
    length = np.linalg.norm(edge, axis=1)
    return tuple(zip(*(column.tolist() for column in (*poly.T, *edge.T, length))))


def circle_gap(ego_circles, ego_circle_r, other_circles, other_circle_r,
               clip: bool = True) -> np.ndarray:
    """Gap between two footprints given by their covering circles [m], >= 0.

    Args:
        ego_circles: (..., C, 2) centres of the ego's covering circles [m]
            (footprint.covering_circles).
        ego_circle_r: (..., C) radii of the ego's covering circles [m].
        other_circles: (..., M, C, 2) centres of the others' covering circles [m].
        other_circle_r: (..., M, C) radii of the others' covering circles [m].
        clip: clip the gap at 0; False: negative values are the deepest circle overlap.

    Returns:
        (..., M) smallest circle-to-circle gap per other agent, clipped at 0 [m] (with clip).

    Footprints from footprint.covering_circles have equal radii within a footprint, and a
    pedestrian's circles coincide; then the gap is the smallest centre distance minus the two
    radii, and repeated circles are compared once -- the same floating-point result as the
    pairwise minimum (subtracting a constant and the square root are monotone), for a
    fraction of the work. Circle centres may also be derivative-carrying arrays
    (marl_social.agents.irl.jets.Jet); those take the pairwise way.
    """
    ego_circle_r, other_circle_r = np.asarray(ego_circle_r), np.asarray(other_circle_r)
    arrays = isinstance(ego_circles, np.ndarray) and isinstance(other_circles, np.ndarray)
    if arrays and _constant_last_axis(ego_circle_r) and _constant_last_axis(other_circle_r):
        ego_circles = _distinct_circles(ego_circles)
        other_circles = _distinct_circles(other_circles)
        # smallest squared distance over the few circle pairs, one pair at a time: no
        # (..., M, C, C) array and no reduction over tiny trailing axes
        nearest = None
        for i in range(ego_circles.shape[-2]):
            ex, ey = ego_circles[..., None, i, 0], ego_circles[..., None, i, 1]
            for j in range(other_circles.shape[-2]):
                dx, dy = ex - other_circles[..., j, 0], ey - other_circles[..., j, 1]
                d2 = dx * dx + dy * dy
                nearest = d2 if nearest is None else np.minimum(nearest, d2)
        gap = np.sqrt(nearest) - ego_circle_r[..., None, 0] - other_circle_r[..., 0]
    else:
        dx = ego_circles[..., None, :, None, 0] - other_circles[..., :, None, :, 0]
        dy = ego_circles[..., None, :, None, 1] - other_circles[..., :, None, :, 1]
        dist = np.sqrt(dx * dx + dy * dy)
        gap = dist - ego_circle_r[..., None, :, None] - other_circle_r[..., :, None, :]
        gap = gap.min(axis=(-1, -2))
    return np.maximum(gap, 0.0) if clip else gap


def _constant_last_axis(values: np.ndarray) -> bool:
    """Whether every (..., C) row of `values` holds one value."""
    return values.shape[-1] <= 1 or bool((values[..., 1:] == values[..., :1]).all())


def _distinct_circles(circles: np.ndarray) -> np.ndarray:
    """(..., C, 2) circle centres, or (..., 1, 2) when every footprint's circles coincide."""
    if circles.shape[-2] > 1 and (circles[..., 1:, :] == circles[..., :1, :]).all():
        return circles[..., :1, :]
    return circles


def object_sum(values) -> np.ndarray:
    """(...) values (..., M) summed over the others' (last) axis, in one order for any layout.

    np.sum's order along a contiguous axis: one by one below 8 values, numpy's pairwise
    summation from 8 on (sim/pairwise_sum.py, which the compiled kernels call). np.sum alone
    would add a strided axis one by one instead, so its bits would depend on how the array
    happens to be laid out in memory; from 8 others a strided array is copied first.
    """
    if isinstance(values, np.ndarray) and values.shape[-1] >= 8 and (
            values.strides[-1] != values.itemsize or not values.flags.c_contiguous):
        values = np.ascontiguousarray(values)
    return np.sum(values, axis=-1)


def _crosswalk_conflict(occ_ego, occ_other, pair_mask) -> np.ndarray:
    """(...) one crosswalk's conflict term.

    The ego's occupancy (...) times the summed occupancy occ_other (..., M) of its others of
    the other kind (pair_mask (..., M)), summed by `object_sum`.
    """
    return occ_ego * object_sum(np.where(pair_mask, occ_other, 0.0))


class StepInputs(NamedTuple):
    """What one step's features of a batch of egos depend on (`step_features`' arguments).

    Attributes:
        lateral_m: lateral offset from the route [m].
        speed_mps: speed [m/s].
        v_ref_mps: reference speed [m/s].
        accel_mps2: acceleration [m/s^2].
        prev_accel_mps2: last step's acceleration [m/s^2].
        ego_xy: (..., 2) centre [m] (or a Jet, agents/irl/jets.py).
        ego_radius: (...) bounding radius [m].
        ego_is_ped: (...) bool.
        ego_circles: (..., C, 2) covering-circle centres [m] (footprint.covering_circles).
        ego_circle_r: (..., C) their radii [m].
        other_xy: (..., M, 2) the others' centres [m].
        other_radius: (..., M) their bounding radii [m].
        other_is_ped: (..., M) bool.
        other_circles: (..., M, C, 2) their covering-circle centres [m].
        other_circle_r: (..., M, C) their radii [m].
        other_mask: (..., M) bool, the others that count (not absent, not the ego).
        crosswalks: the map's crosswalks.
        gap: circle_gap(ego, others) computed by the caller, or None.
        yield_zones: the conflict zones the ego yields at, each (polygon (V, 2) [m], claim
            (..., M) in 0..1: how much each other with the right of way there claims the
            zone, 0 for the others; broadcast against other_mask).
        other_occupancy: the others' crosswalk_occupancy per crosswalk, or None.
    """

    lateral_m: object
    speed_mps: object
    v_ref_mps: object
    accel_mps2: object
    prev_accel_mps2: object
    ego_xy: object
    ego_radius: object
    ego_is_ped: object
    ego_circles: object
    ego_circle_r: object
    other_xy: object
    other_radius: object
    other_is_ped: object
    other_circles: object
    other_circle_r: object
    other_mask: object
    crosswalks: tuple
    gap: object = None
    yield_zones: tuple = ()
    other_occupancy: object = None


def _feature_terms(inputs: StepInputs, needed: tuple = (True,) * N_FEATURES) -> list:
    """The six per-step features in FEATURE_NAMES order (None where not needed)."""
    (lateral_m, speed_mps, v_ref_mps, accel_mps2, prev_accel_mps2, ego_xy, ego_radius,
     ego_is_ped, ego_circles, ego_circle_r, other_xy, other_radius, other_is_ped,
     other_circles, other_circle_r, other_mask, crosswalks, gap, yield_zones,
     other_occupancy) = inputs
    terms = [None] * N_FEATURES
    if needed[0]:
        terms[0] = np.asarray(lateral_m, dtype=np.float64) ** 2
    if needed[1]:
        terms[1] = (np.asarray(speed_mps) - v_ref_mps) ** 2
    if needed[2]:
        terms[2] = np.asarray(accel_mps2) ** 2
    if needed[3]:
        terms[3] = (np.asarray(accel_mps2) - prev_accel_mps2) ** 2
    if needed[4]:
        if gap is None:
            gap = circle_gap(ego_circles, ego_circle_r, other_circles, other_circle_r)
        terms[4] = object_sum(np.where(other_mask, np.exp(-gap), 0.0))
    if needed[5]:
        conflict = 0.0
        if crosswalks:
            other_kind_differs = np.asarray(other_is_ped) != np.asarray(ego_is_ped)[..., None]
            pair_mask = other_mask & other_kind_differs
            if not pair_mask.any() and not getattr(ego_xy, "is_jet", False):
                # no pair of the two kinds: each crosswalk adds occupancy (finite, >= 0) times
                # 0.0, +0.0 everywhere; the same zeros without computing the occupancies
                crosswalks = ()
                conflict = conflict + np.zeros(_no_pair_shape(
                    ego_xy, ego_radius, other_xy, other_radius, pair_mask, other_occupancy))
            for i, cw in enumerate(crosswalks):
                occ_other = (crosswalk_occupancy(other_xy, other_radius, cw)
                             if other_occupancy is None else other_occupancy[i])
                conflict = conflict + _crosswalk_conflict(
                    crosswalk_occupancy(ego_xy, ego_radius, cw), occ_other, pair_mask)
        for polygon, claim in yield_zones:
            occ_ego = zone_occupancy(ego_circles, ego_circle_r, polygon)
            conflict = conflict + occ_ego * object_sum(np.where(other_mask, claim, 0.0))
        terms[5] = conflict
    return terms


def _no_pair_shape(ego_xy, ego_radius, other_xy, other_radius, pair_mask, other_occupancy
                   ) -> tuple:
    """The shape of a crosswalk's _crosswalk_conflict term (the broadcast of its operands)."""
    occ_other = (np.broadcast_shapes(np.shape(other_xy)[:-1], np.shape(other_radius))
                 if other_occupancy is None else np.shape(other_occupancy[0]))
    return np.broadcast_shapes(np.shape(ego_xy)[:-1], np.shape(ego_radius),
                               np.broadcast_shapes(pair_mask.shape, occ_other)[:-1])


def step_features(**kwargs) -> np.ndarray:
    """Feature vector phi of one step for a batch of egos.

    Keyword arguments: the fields of StepInputs (gap, yield_zones and other_occupancy
    optional). Leading dimensions broadcast. Returns (..., N_FEATURES) in FEATURE_NAMES order.
    """
    terms = _feature_terms(StepInputs(**kwargs))
    return np.stack(np.broadcast_arrays(*terms), axis=-1)


def step_cost(theta: np.ndarray, **kwargs) -> np.ndarray:
    """Cost theta^T phi of one step (same arguments as step_features).

    Computes only the features whose weight is non-zero. Returns the broadcast batch shape (...).
    """
    theta = np.asarray(theta, dtype=np.float64)
    terms = _feature_terms(StepInputs(**kwargs), tuple(bool(w != 0.0) for w in theta))
    total = 0.0
    for weight, term in zip(theta, terms):
        if term is not None:
            total = total + weight * term
    return total


class AgentMotion(NamedTuple):
    """What n agents' own features depend on this step, (n,) each."""

    lateral_m: np.ndarray  # lateral offsets from the routes [m]
    speed_mps: np.ndarray  # speeds [m/s]
    v_ref_mps: np.ndarray | float  # reference speeds [m/s] (one for all, or (n,))
    accel_mps2: np.ndarray  # accelerations this step [m/s^2]
    prev_accel_mps2: np.ndarray  # accelerations last step [m/s^2]


class AgentFootprints(NamedTuple):
    """Where n agents are and the footprints they cover this step."""

    xy: np.ndarray  # (n, 2) centres [m]
    radius: np.ndarray  # (n,) bounding radii [m]
    is_ped: np.ndarray  # (n,) bool
    circles: np.ndarray  # (n, C, 2) covering-circle centres [m] (footprint.circle_layout)
    circle_r: np.ndarray  # (n, C) their radii [m], one value per footprint


def pairwise_step_features(motion: AgentMotion, bodies: AgentFootprints, other_mask: np.ndarray,
                           crosswalks: tuple, kinds_differ: np.ndarray | None = None
                           ) -> np.ndarray:
    """`step_features` of n agents who are each other's others (the env's reward), fast.

    The same features, bit for bit, as ``step_features`` with ego = every agent and others =
    the same n agents (tests/sim/test_costs.py checks it), compiled (sim/feature_kernels.py):
    the circle gaps, the first five features and the crosswalks' row sums, any n (np.exp and
    crosswalk_occupancy's np.tanh stay numpy's); each crosswalk's occupancy is computed once
    for egos and others alike.

    Args:
        motion: the agents' offsets, speeds and accelerations.
        bodies: their positions and covering circles.
        other_mask: (n, n) bool, other_mask[i, j]: agent j counts as an other of agent i.
        crosswalks: the map's crosswalks.
        kinds_differ: (n, n) bool, is_ped[j] != is_ped[i] (computed when None).

    Returns:
        (n, N_FEATURES) in FEATURE_NAMES order.
    """
    lateral_m, speed_mps, v_ref_mps, accel_mps2, prev_accel_mps2 = motion
    xy, radius, is_ped, circles, circle_r = bodies
    kernels = feature_kernels()
    gap = kernels.circle_gap_matrix(circles, circle_r[:, 0])
    out = kernels.feature_rows(lateral_m, speed_mps, np.broadcast_to(v_ref_mps, len(xy)),
                               accel_mps2, prev_accel_mps2, np.exp(-gap), other_mask)
    out[:, 5] = _pairwise_conflict(
        xy, radius, is_ped, other_mask, crosswalks, kinds_differ,
        lambda occ, pair_mask: occ * kernels.occupancy_sums(occ, pair_mask))
    return out


def _pairwise_conflict(xy, radius, is_ped, other_mask, crosswalks, kinds_differ, term):
    """(n,) conflict feature of n agents who are each other's others (or 0.0: no crosswalk).

    Per crosswalk `term(occupancy, pair_mask)`: each agent's occupancy times the summed
    occupancy of its others of the other kind (the compiled row sums; `_crosswalk_conflict`
    in the tests' numpy reference), added up over the crosswalks from 0.0 as `_feature_terms`
    adds them.
    """
    conflict = 0.0
    if crosswalks:
        if kinds_differ is None:
            kinds_differ = is_ped[None, :] != is_ped[:, None]
        pair_mask = other_mask & kinds_differ
        for cw in crosswalks:
            occ = crosswalk_occupancy(xy, radius, cw)  # egos' and others' alike
            conflict = conflict + term(occ, pair_mask)
    return conflict
