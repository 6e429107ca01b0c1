"""Candidate longitudinal plans along a route, evaluated against scene hypotheses.

A candidate is a first acceleration u (held for the first segment) followed by a continuation c
(held to the end of the horizon; models/rollouts.py, the scene: models/scene_prediction.py).
All A x C candidates are rolled out at once (path-velocity
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

from marl_social.models.circle_gaps import (
    circle_pair_gap,
    scene_circles,
    scene_crosswalk_occupancy,
)
from marl_social.models.rollouts import CandidateSet, _governed, _plan_constants, _rollout
from marl_social.models.scene_prediction import ScenePrediction
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
