"""Candidate longitudinal plans along a route, evaluated against scene hypotheses.

A candidate is a first acceleration u (held for the first segment) followed by a continuation c
(held to the end of the horizon). All A x C candidates are rolled out at once (path-velocity
decomposition: position along the route, the route gives x, y, heading) and their per-step costs
(sim/costs.py) computed against L scene hypotheses in one batch. The human drivers' Q*
(models/driver.py) and the robot's contingency MPC (agents/robot/mpc.py) are both built on this.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from marl_social.models import kernel_loading
from marl_social.models.circle_gaps import (
    circle_pair_gap,
    scene_circles,
    scene_crosswalk_occupancy,
)
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.costs import (
    crosswalk_occupancy,
    step_cost,
    step_features,
    zone_occupancy,
)
from marl_social.sim.dynamics import DT_S
from marl_social.sim.footprint import circle_layout, covering_circles
from marl_social.sim.road_map import Crosswalk, Route
from marl_social.sim.route_rules import CurveSpeed


@dataclass(frozen=True)
class ScenePrediction:
    """Predicted others for one or more hypotheses (L of them), M objects, T steps.

    Attributes:
        xy: (L, M, T, 2) positions after each planner step [m].
        heading: (L, M, T) headings after each planner step [rad].
        length_m: (L, M) footprint lengths [m].
        width_m: (L, M) footprint widths [m].
        radius_m: (L, M) footprint bounding radii [m].
        is_pedestrian: (L, M) bool.
        mask: (L, M) bool, object present in that hypothesis.
    """

    xy: np.ndarray
    heading: np.ndarray
    length_m: np.ndarray
    width_m: np.ndarray
    radius_m: np.ndarray
    is_pedestrian: np.ndarray
    mask: np.ndarray

    @classmethod
    def from_tracks(cls, tracks, times_s: np.ndarray, mask: np.ndarray | None = None,
                    predicted_xy: np.ndarray | None = None) -> ScenePrediction:
        """One hypothesis: every track of a TrackSet at constant velocity (or as predicted).

        Footprints are at the tracks' headings (TrackSet.heading_rad, perception/tracking.py).

        Args:
            tracks: the TrackSet, M tracks.
            times_s: (T,) prediction times [s].
            mask: (1, M) bool, the tracks present in the scene (default: all).
            predicted_xy: (M, T, 2) the tracks' positions at times_s [m] (default: constant
                velocity, TrackSet.predict_xy).
        """
        if predicted_xy is None and _float_arrays(tracks.xy, tracks.velocity, tracks.heading_rad,
                                                  times_s):
            # predict_xy's arithmetic and the repeated headings in one compiled call
            xy, heading = kernel_loading.load_all()[2].constant_velocity_scene(  # scene_kernels
                tracks.xy, tracks.velocity, tracks.heading_rad, times_s)
        else:
            if predicted_xy is None:
                predicted_xy = tracks.predict_xy(times_s)
            xy = predicted_xy[None]  # (1, M, T, 2)
            heading = tracks.heading_rad[None, :, None].repeat(xy.shape[2], axis=2)  # (1, M, T)
        radius = 0.5 * np.hypot(tracks.length_m, tracks.width_m)
        if mask is None:  # every track: a copy of a row of Trues (faster than np.ones)
            m = len(tracks)
            mask = (_ALL_PRESENT[:, :m] if m <= _ALL_PRESENT.shape[1]
                    else np.ones((1, m), dtype=bool)).copy()
        return cls(xy, heading, tracks.length_m[None], tracks.width_m[None], radius[None],
                   tracks.is_pedestrian[None], mask)

    def with_extra(self, xy, heading, length_m, width_m, is_pedestrian, mask) -> ScenePrediction:
        """Append one object per hypothesis.

        The L of self must be 1 (broadcast) or L.

        Args:
            xy: (L, T, 2) positions after each planner step [m].
            heading: (L, T) headings after each planner step [rad].
            length_m: (L,) footprint lengths [m].
            width_m: (L,) footprint widths [m].
            is_pedestrian: (L,) bool.
            mask: (L,) bool, object present in that hypothesis.
        """
        n_hyp = len(mask)
        radius = 0.5 * np.hypot(length_m, width_m)

        def append(mine: np.ndarray, extra) -> np.ndarray:
            """(n_hyp, M + 1, ...): mine (1 or n_hyp, M, ...) repeated, then extra (n_hyp, ...)."""
            extra = np.asarray(extra)
            out = np.empty((n_hyp, mine.shape[1] + 1) + mine.shape[2:],
                           dtype=np.result_type(mine.dtype, extra.dtype))  # np.concatenate's
            out[:, :-1] = mine
            out[:, -1] = extra
            return out

        return ScenePrediction(
            append(self.xy, xy), append(self.heading, heading),
            append(self.length_m, length_m), append(self.width_m, width_m),
            append(self.radius_m, radius), append(self.is_pedestrian, is_pedestrian),
            append(self.mask, mask),
        )


_ALL_PRESENT = np.ones((1, 64), dtype=bool)
_ALL_PRESENT.setflags(write=False)


def _float_arrays(xy, velocity, heading, times_s) -> bool:
    """Whether scene_kernels.constant_velocity_scene takes these arrays.

    float64 xy (M, 2), velocity (M, 2), heading (M,) and times_s (T,).
    """
    return (type(xy) is type(velocity) is type(heading) is type(times_s) is np.ndarray
            and xy.dtype == velocity.dtype == heading.dtype == times_s.dtype == np.float64
            and times_s.ndim == 1 and xy.shape == velocity.shape == (len(heading), 2)
            and heading.ndim == 1)


@dataclass(frozen=True)
class CandidateSet:
    """The candidate plans.

    Attributes:
        first_actions_mps2: (A,) first accelerations [m/s^2].
        continuations_mps2: (C,) accelerations after the first segment [m/s^2].
        first_segment_s: how long the first action is held [s].
        horizon_s: planning horizon [s].
        plan_dt_s: rollout step [s]; per-step costs are scaled by plan_dt / DT_S so that sums
            are in simulator-step units.
    """

    first_actions_mps2: tuple
    continuations_mps2: tuple
    first_segment_s: float
    horizon_s: float
    plan_dt_s: float = 0.25

    def __post_init__(self):
        if not self.horizon_s > self.first_segment_s >= self.plan_dt_s > 0:
            raise ValueError("CandidateSet: need horizon_s > first_segment_s >= plan_dt_s > 0")
        if not len(self.first_actions_mps2) or not len(self.continuations_mps2):
            raise ValueError("CandidateSet: need at least one first action and one "
                             "continuation")

    @property
    def n_steps(self) -> int:
        return round(self.horizon_s / self.plan_dt_s)

    @property
    def n_first(self) -> int:
        return round(self.first_segment_s / self.plan_dt_s)

    @property
    def plan_times_s(self) -> np.ndarray:
        """(T,) times of the rollout's states after each planner step [s]."""
        return (np.arange(self.n_steps) + 1) * self.plan_dt_s


def rollout_speeds(v0: float, accel: np.ndarray, dt_s: float = DT_S) -> tuple[np.ndarray, ...]:
    """Speeds and distances of acceleration profiles with the v >= 0 limit, without a time loop.

    v_{k+1} = max(0, v_k + a_k dt) is a Lindley recursion: with S_k = v0 + sum_{i<k} a_i dt,
    v_k = S_k - min(0, min_{j<=k} S_j).

    Args:
        v0: initial speed [m/s].
        accel: (..., T) commanded accelerations [m/s^2].
        dt_s: step length [s].

    Returns:
        v (..., T) speed after each step [m/s], ds (..., T) distance travelled up to each step
        [m], a_eff (..., T) effective acceleration (dv / dt) [m/s^2].
    """
    return _rollout(v0, np.cumsum(accel * dt_s, axis=-1), dt_s)


def _rollout(v0: float, increments: np.ndarray, dt_s: float) -> tuple[np.ndarray, ...]:
    """rollout_speeds from increments (..., T) = cumsum(accel * dt_s) [m/s] (same arithmetic)."""
    shape = increments.shape
    s_full = np.empty(shape[:-1] + (shape[-1] + 1,))
    s_full[..., 0] = v0
    np.add(v0, increments, out=s_full[..., 1:])
    v_full = s_full - np.minimum(0.0, np.minimum.accumulate(s_full, axis=-1))
    v = v_full[..., 1:]
    ds = np.cumsum(0.5 * (v + v_full[..., :-1]) * dt_s, axis=-1)
    return v, ds, (v - v_full[..., :-1]) / dt_s


@dataclass(frozen=True)
class _PlanConstants:
    """What a CandidateSet's rollouts share, computed once per set (read-only arrays).

    Attributes:
        continuations: (C,) continuation accelerations [m/s^2].
        increments: (A, C, T) cumsum(accel * plan_dt) of the candidates' commands [m/s].
    """

    continuations: np.ndarray
    increments: np.ndarray


def cached_or_computed(cached, key):
    """cached(key) for a hashable key; the wrapped function's result for an unhashable one.

    Args:
        cached: a functools.lru_cache-wrapped function of one argument.
        key: its argument (e.g. a frozen dataclass with a field given as a list).
    """
    try:
        return cached(key)
    except TypeError:  # a field that cannot be hashed (e.g. accelerations given as a list)
        return cached.__wrapped__(key)


def _plan_constants(cands: CandidateSet) -> _PlanConstants:
    """The set's _PlanConstants (cached for hashable sets, computed for the others)."""
    return cached_or_computed(_cached_plan_constants, cands)


@functools.lru_cache(maxsize=64)
def _cached_plan_constants(cands: CandidateSet) -> _PlanConstants:
    first = np.asarray(cands.first_actions_mps2, dtype=np.float64)
    cont = np.asarray(cands.continuations_mps2, dtype=np.float64)
    step = np.arange(cands.n_steps)
    accel = np.where(step < cands.n_first, first[:, None, None], cont[None, :, None])  # (A,C,T)
    out = _PlanConstants(cont, np.cumsum(accel * cands.plan_dt_s, axis=-1))
    for array in (out.continuations, out.increments):
        array.setflags(write=False)
    return out


@functools.lru_cache(maxsize=64)
def _vehicle_circles(length_m: float, width_m: float) -> tuple[np.ndarray, float]:
    """A vehicle's covering circles (footprint.circle_layout): offsets (C,) [m], radius [m]."""
    along, radius = circle_layout(length_m, width_m, False)
    along.setflags(write=False)
    return along, float(radius[0])


@dataclass(frozen=True)
class CandidateEvaluation:
    """Candidates against L hypotheses.

    Attributes:
        step_cost: (L, A, C, T) theta . phi per planner step, in simulator-step units.
        v: (A, C, T) speeds [m/s].
        a_eff: (A, C, T) effective accelerations [m/s^2].
        min_gap_m: (L, A, C) smallest covering-circle gap to any present object [m]
            (inf without objects); only with geometry=True.
        conflict: (L, A, C) largest per-step crosswalk conflict (own occupancy x a pedestrian's)
            [0..1]; only with geometry=True.
        static_gap_m: (A, C) smallest gap between the covering circles and the bounding boxes
            of the static polygons [m] (inf without polygons); only with geometry=True.
        min_vehicle_gap_m: (L, A, C) as min_gap_m, vehicles only; only with geometry=True.
        vehicle_clearance_m: (L, A, C) as min_vehicle_gap_m but not clipped at 0 (negative:
            the deepest overlap of covering circles) [m]; only with geometry=True.
        curve_excess_mps: (A, C) largest excess of the speed over the curve speed along the
            plan [m/s] (<= 0: within it everywhere); only with curve_speed.
        feature_totals: (L, A, C, N_FEATURES) per-feature totals over the horizon, in
            simulator-step units (step_cost summed over T is theta . feature_totals); only with
            features=True.
        travel_m: (A, C, T) distance travelled along the route up to each step [m].
    """

    step_cost: np.ndarray
    v: np.ndarray
    a_eff: np.ndarray
    min_gap_m: np.ndarray | None = None
    conflict: np.ndarray | None = None
    static_gap_m: np.ndarray | None = None
    min_vehicle_gap_m: np.ndarray | None = None
    feature_totals: np.ndarray | None = None
    travel_m: np.ndarray | None = None
    vehicle_clearance_m: np.ndarray | None = None
    curve_excess_mps: np.ndarray | None = None


def zone_claims(scene: ScenePrediction, polygon: np.ndarray, priority: np.ndarray,
                margin_s: float, dt_s: float) -> np.ndarray:
    """(L, M, T) how much each priority object claims a zone at each planner step, 0..1.

    An object claims the zone when it occupies it now or will within margin_s, extrapolating
    its predicted motion at its current predicted velocity (beyond the horizon too); the claim
    is the largest occupancy (sim/costs.zone_occupancy) over offsets 0, dt, ..., margin_s.
    Computed for the present priority objects only (the others' claim is 0).

    Args:
        scene: the predicted objects (L hypotheses, M objects, T steps).
        polygon: (V, 2) the zone's convex outline, counter-clockwise [m].
        priority: (L, M) bool, the objects with the right of way in the zone.
        margin_s: the time margin [s], >= 0.
        dt_s: the planner step [s].
    """
    claim = np.zeros(scene.heading.shape)  # 0 for the others: only claimants are computed
    rows, cols = np.nonzero(np.asarray(priority, dtype=bool) & scene.mask)
    if not len(rows):
        return claim
    xy = scene.xy[rows, cols]  # (P, T, 2)
    if xy.shape[1] > 1:  # np.gradient(xy, dt_s, axis=1), the same arithmetic without its overhead
        velocity = np.empty_like(xy)
        velocity[:, 1:-1] = (xy[:, 2:] - xy[:, :-2]) / (2.0 * dt_s)
        velocity[:, 0] = (xy[:, 1] - xy[:, 0]) / dt_s
        velocity[:, -1] = (xy[:, -1] - xy[:, -2]) / dt_s
    else:
        velocity = np.zeros_like(xy)
    offsets = np.arange(round(margin_s / dt_s) + 1) * dt_s  # (J,)
    ahead = xy[None] + offsets[:, None, None, None] * velocity[None]  # (J, P, T, 2)
    circles, radii = covering_circles(ahead, scene.heading[rows, cols][None],
                                      scene.length_m[rows, cols][None, :, None],
                                      scene.width_m[rows, cols][None, :, None],
                                      scene.is_pedestrian[rows, cols][None, :, None])
    claim[rows, cols] = zone_occupancy(circles, radii, polygon).max(axis=0)  # (P, T)
    return claim


def collision_free_totals(ev: CandidateEvaluation) -> np.ndarray:
    """(L, A, C) total costs of the candidates, +inf for plans that touch a predicted vehicle.

    Every plan whose covering circles touch a predicted vehicle (min_vehicle_gap_m == 0; needs
    geometry=True) is set to +inf, so that a driver's Q* never chooses to run into a car: the safety feature alone saturates at 1 per
    step, less than the speed cost of stopping behind a stopped car. (Pedestrians are kept
    out of the ego's way by the crosswalk feature.) A first action all of whose continuations
    collide gets Q* = inf. Under a hypothesis where every plan collides (e.g. stopped so
    close behind a car that the covering circles, which overestimate a car's length, already
    touch), only the plans with the largest clearance (least overlap) keep their costs: a
    driver stopped too close behind a car does not drive on into it, one with a car too close
    behind it drives away.
    """
    total = ev.step_cost.sum(axis=-1)
    colliding = ev.min_vehicle_gap_m <= 0.0
    if not np.count_nonzero(colliding):  # none (count_nonzero: faster than .any())
        return total
    hopeless = colliding.all(axis=(-1, -2), keepdims=True)
    if not np.count_nonzero(hopeless):
        return np.where(colliding, np.inf, total)
    clearance = ev.vehicle_clearance_m  # (L, A, C)
    best = clearance >= clearance.max(axis=(-1, -2), keepdims=True)
    return np.where(np.where(hopeless, ~best, colliding), np.inf, total)


def _governed(v: np.ndarray, ds: np.ndarray, v0: float, cont: np.ndarray, n_first: int,
              dt_s: float, v_ceiling_mps: float) -> tuple[np.ndarray, ...]:
    """Accelerating continuations stop accelerating at a speed ceiling (then hold it).

    "Speed up to the curve speed, then keep it": without it, a driver in a bend could only
    choose between holding its speed and accelerating past the curve speed, and would keep
    putting the acceleration off. The continuation is monotone, so clamping it is exact.

    Args:
        v: (A, C, T) speeds of the plans [m/s].
        ds: (A, C, T) their distances [m] (returned as they are for an infinite ceiling).
        v0: initial speed [m/s].
        cont: (C,) continuation accelerations [m/s^2].
        n_first: steps of the first segment.
        dt_s: step [s].
        v_ceiling_mps: the ceiling [m/s] (inf: nothing changes).

    Returns:
        v, ds, a_eff as rollout_speeds returns them.
    """
    v_full = np.empty(v.shape[:-1] + (v.shape[-1] + 1,))
    v_full[..., 0] = v0
    if not np.isfinite(v_ceiling_mps):
        v_full[..., 1:] = v
        return v, ds, (v - v_full[..., :-1]) / dt_s
    v1 = v[..., n_first - 1: n_first]  # (A, C, 1) speed at the end of the first segment
    rising = (cont > 0)[None, :, None] & (np.arange(v.shape[-1]) >= n_first)
    np.copyto(v_full[..., 1:], np.minimum(v, np.maximum(v1, v_ceiling_mps)), where=rising)
    np.copyto(v_full[..., 1:], v, where=~rising)
    v = v_full[..., 1:]
    ds = np.cumsum(0.5 * (v + v_full[..., :-1]) * dt_s, axis=-1)
    return v, ds, (v - v_full[..., :-1]) / dt_s


class PlanningEgo(NamedTuple):
    """Who plans and from where: what `evaluate_candidates` rolls out and costs.

    Attributes:
        cands: the candidate plans.
        theta: (N_FEATURES,) the planner's cost weights.
        v_ref_mps: its reference speed [m/s].
        vehicle: its body and limits.
        route: its route.
        s0: its arc length along the route [m].
        v0: its speed [m/s].
        prev_accel: its previous acceleration [m/s^2].
    """

    cands: CandidateSet
    theta: np.ndarray
    v_ref_mps: float
    vehicle: VehicleParams
    route: Route
    s0: float
    v0: float
    prev_accel: float


class Surroundings(NamedTuple):
    """What the plans are costed against.

    Attributes:
        scene: L hypotheses of M predicted objects at the candidates' plan times.
        crosswalks: the map's crosswalks.
        yield_zones: the conflict zones the ego yields at, each (polygon (V, 2) [m], priority
            (L, M) bool: the scene objects with the right of way there); they add to the
            conflict feature (sim/costs.py) the ego's occupancy times each priority object's
            claim on the zone (`zone_claims`: in it now or within yield_margin_s at its
            predicted velocity).
        yield_margin_s: see yield_zones [s].
        curve_speed: the curve speed along the route (sim/route_rules.CurveSpeed), for
            curve_excess_mps; None: not computed.
    """

    scene: ScenePrediction
    crosswalks: tuple[Crosswalk, ...]
    yield_zones: tuple = ()
    yield_margin_s: float = 0.0
    curve_speed: CurveSpeed | None = None


LARGEST_SPEED_MPS = 1e6  # the planners' range of initial speeds and arc lengths (the
LARGEST_ARC_LENGTH_M = 1e12  # compiled kernels' curve-speed grid index then fits an int64)


def checked_initial_state(s0: float, v0: float) -> tuple[float, float]:
    """(s0, v0) [m, m/s] of a plan's start, checked: finite and within the planners' range.

    A speed of -0.0 is 0.0 (+0.0 returned). Raises ValueError naming the value otherwise.
    """
    if not abs(s0) < LARGEST_ARC_LENGTH_M:
        raise ValueError(f"a plan's initial arc length s0={s0} m must be finite and below "
                         f"{LARGEST_ARC_LENGTH_M:g} m in magnitude")
    if not abs(v0) < LARGEST_SPEED_MPS:
        raise ValueError(f"a plan's initial speed v0={v0} m/s must be finite and below "
                         f"{LARGEST_SPEED_MPS:g} m/s in magnitude")
    return s0, v0 + 0.0


def evaluate_candidates(ego: PlanningEgo, around: Surroundings, geometry: bool = False,
                        static_boxes: np.ndarray | None = None, features: bool = False,
                        vehicle_gaps_only: bool = False) -> CandidateEvaluation:
    """Roll out every candidate of `ego` and cost it against every hypothesis `around` it.

    See the module docstring, PlanningEgo and Surroundings.

    features: also return the per-feature totals (for discrete-choice IRL, agents/irl/choice.py);
    the costs are computed exactly as without it.

    static_boxes: (S, 4) [xmin, ymin, xmax, ymax] of the static polygons [m], for the
    static clearance (geometry=True only; boxes contain their polygons, so it is conservative).

    vehicle_gaps_only: with geometry, only the vehicle gaps that collision_free_totals needs
    (min_vehicle_gap_m, vehicle_clearance_m); min_gap_m, conflict and static_gap_m stay None.
    """
    cands, theta, v_ref_mps, vehicle, route, s0, v0, prev_accel = ego
    s0, v0 = checked_initial_state(s0, v0)
    scene, crosswalks, yield_zones, yield_margin_s, curve_speed = around
    dt = cands.plan_dt_s
    plan = _plan_constants(cands)
    v, ds, a_eff = _rollout(v0, plan.increments, dt)
    curve_excess = None
    if curve_speed is not None:
        v, ds, a_eff = _governed(v, ds, v0, plan.continuations, cands.n_first, dt,
                                 float(curve_speed.at(s0 + ds).min()))
        curve_excess = (v - curve_speed.at(s0 + ds)).max(axis=-1)  # (A, C)
    xy, heading = route.point_at(s0 + ds)  # (A, C, T, 2), (A, C, T)
    # the ego's covering circles (footprint.covering_circles), circle axis first: (K, A, C, T)
    along, ego_circle_r = _vehicle_circles(vehicle.length_m, vehicle.width_m)
    ego_x = xy[..., 0] + along[:, None, None, None] * np.cos(heading)
    ego_y = xy[..., 1] + along[:, None, None, None] * np.sin(heading)
    ego_radius = 0.5 * math.hypot(vehicle.length_m, vehicle.width_m)
    ox, oy, other_r = scene_circles(scene)  # (J, L, M, T) x 2, (L, M)
    # others to (L, 1, 1, T, M, ...) so they broadcast against the (A, C, T) candidates
    to_cand = lambda a: a.swapaxes(1, 2)[:, None, None]
    other_xy = to_cand(scene.xy)
    other_radius = scene.radius_m[:, None, None, None, :]
    other_is_ped = scene.is_pedestrian[:, None, None, None, :]
    other_mask = scene.mask[:, None, None, None, :]
    prev = np.empty_like(a_eff)
    prev[..., 0] = prev_accel
    prev[..., 1:] = a_eff[..., :-1]
    # shared by the safety cost and the gap constraint
    raw_gap = circle_pair_gap(ego_x, ego_y, ego_circle_r, ox, oy, other_r)
    gap = np.maximum(raw_gap, 0.0)  # (L, A, C, T, M)
    ego_circles = ego_r = None  # (A, C, T, K, 2), (A, C, T, K): only where they are needed
    if yield_zones or static_boxes is not None:
        ego_circles = np.moveaxis(np.stack((ego_x, ego_y), axis=-1), 0, -2)
        ego_r = np.broadcast_to(ego_circle_r, ego_circles.shape[:-1])
    feature_args = {
        "lateral_m": 0.0, "speed_mps": v, "v_ref_mps": v_ref_mps, "accel_mps2": a_eff,
        "prev_accel_mps2": prev, "ego_xy": xy, "ego_radius": ego_radius, "ego_is_ped": False,
        "ego_circles": ego_circles, "ego_circle_r": ego_r, "other_xy": other_xy,
        "other_radius": other_radius, "other_is_ped": other_is_ped, "other_circles": None,
        "other_circle_r": None, "other_mask": other_mask, "crosswalks": crosswalks, "gap": gap,
        "other_occupancy": scene_crosswalk_occupancy(scene, crosswalks) if crosswalks else None,
    }
    if yield_zones:
        feature_args["yield_zones"] = tuple(
            (polygon, to_cand(zone_claims(scene, polygon, priority, yield_margin_s, dt)))
            for polygon, priority in yield_zones)
    cost = step_cost(theta, **feature_args) * (dt / DT_S)  # a float 0.0 if every weight is 0
    if np.shape(cost) != (len(scene.mask),) + v.shape:
        cost = np.broadcast_to(cost, (len(scene.mask),) + v.shape)
    totals = None
    if features:
        phi = step_features(**feature_args) * (dt / DT_S)  # (L or 1, A, C, T, F)
        totals = np.broadcast_to(phi.sum(axis=-2), cost.shape[:-1] + (phi.shape[-1],))
    if not geometry:
        return CandidateEvaluation(cost, v, a_eff, feature_totals=totals, travel_m=ds,
                                   curve_excess_mps=curve_excess)
    n_hyp = len(scene.mask)
    if vehicle_gaps_only:
        clearance = np.full((n_hyp,) + v.shape[:2], np.inf)
        # only the objects that are a present vehicle in some hypothesis can be finite
        cars = np.flatnonzero((scene.mask & ~scene.is_pedestrian).any(axis=0))
        if len(cars):
            if len(cars) < scene.mask.shape[1]:
                raw_gap, other_mask, other_is_ped = (
                    raw_gap[..., cars], other_mask[..., cars], other_is_ped[..., cars])
            clearance = np.broadcast_to(np.where(other_mask & ~other_is_ped, raw_gap, np.inf)
                                        .min(axis=(-1, -2)), clearance.shape)
        return CandidateEvaluation(cost, v, a_eff, None, None, None, np.maximum(clearance, 0.0),
                                   totals, ds, clearance, curve_excess)
    if scene.mask.shape[1]:
        gap = np.where(other_mask, gap, np.inf)
        min_gap = np.broadcast_to(gap.min(axis=(-1, -2)), (n_hyp,) + v.shape[:2])
        vehicle_gap = np.where(other_is_ped, np.inf, gap)
        min_vehicle_gap = np.broadcast_to(vehicle_gap.min(axis=(-1, -2)), min_gap.shape)
        clearance = np.where(other_mask & ~other_is_ped, raw_gap, np.inf)
        clearance = np.broadcast_to(clearance.min(axis=(-1, -2)), min_gap.shape)
    else:
        min_gap = np.full((n_hyp,) + v.shape[:2], np.inf)
        min_vehicle_gap = clearance = min_gap
    conflict = np.zeros((n_hyp,) + v.shape)
    ped_mask = other_mask & other_is_ped
    for cw, occ_other in zip(crosswalks, feature_args["other_occupancy"] or ()):
        occ_ego = crosswalk_occupancy(xy, ego_radius, cw)  # (A, C, T)
        occ_ped = np.where(ped_mask, occ_other, 0.0)
        conflict = np.maximum(conflict, occ_ego * occ_ped.max(axis=-1, initial=0.0))
    static_gap = np.full(v.shape[:2], np.inf)
    if static_boxes is not None and len(static_boxes):
        # only boxes near the candidates' overall bounding box can bind (the 2 m margin is more
        # than any clearance a planner asks for)
        reach = float(ego_r.max()) + 2.0
        lo_all = ego_circles.reshape(-1, 2).min(axis=0) - reach
        hi_all = ego_circles.reshape(-1, 2).max(axis=0) + reach
        near = np.all((static_boxes[:, :2] <= hi_all) & (static_boxes[:, 2:] >= lo_all), axis=1)
        static_boxes = static_boxes[near]
    if static_boxes is not None and len(static_boxes):
        lo, hi = static_boxes[:, :2], static_boxes[:, 2:]
        c = ego_circles[..., None, :]  # (A, C, T, K, 1, 2)
        outside = np.maximum(np.maximum(lo - c, c - hi), 0.0)
        dist = np.sqrt((outside ** 2).sum(axis=-1)) - ego_r[..., None]  # (A, C, T, K, S)
        static_gap = dist.min(axis=(-1, -2, -3))
    return CandidateEvaluation(cost, v, a_eff, min_gap, conflict.max(axis=-1), static_gap,
                               min_vehicle_gap, totals, ds, clearance, curve_excess)
