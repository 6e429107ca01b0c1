"""What the robot's path corridor imposes on its progress: predicted objects, static boxes, curves.

Everything is projected onto the robot's route (path-velocity decomposition). An object occupies
the corridor at a plan step when the lateral extent of its footprint (its four corners projected
on the route) overlaps [-(w/2 + margin), w/2 + margin] around the route, w the robot's width.
Nothing here knows what the object is (pedestrian, car) or why it is there (a crosswalk, a lane):
a crossing pedestrian, a car ahead in the lane and a car crossing an intersection are all an
interval of plan steps during which the object covers [s_rear, s_front] of the robot's path.
While it does, the robot either stays behind it (front <= s_rear - gap: this is also car
following) or is past it (rear >= s_front + gap, from `pass_margin_steps` before it arrives).
Objects beside or behind the robot now are ignored.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from marl_social.models.scene_prediction import ScenePrediction
from marl_social.sim.kernel_cache import load_kernels, route_kernels
from marl_social.sim.road_map import Route


@functools.cache  # asked for several times per plan: a cached call, not load_kernels' lookup
def corridor_kernels():
    """agents/robot/corridor_kernels.py (the corridor test, the MPC's bounds), loaded once."""
    return load_kernels("marl_social.agents.robot", ("corridor_kernels",),
                        "the robot's corridor kernels", 5)[0]

BEHIND, PAST = "behind", "past"


@dataclass(frozen=True)
class PathObject:
    """One predicted object of one hypothesis that occupies the robot's corridor.

    Attributes:
        occupied: (N,) bool, in the corridor at the end of plan step k.
        s_rear_m: (N,) smallest arc length of its footprint along the route [m].
        s_front_m: (N,) largest arc length of its footprint along the route [m].
        k_first: first occupied step.
        k_last: last occupied step.
        is_pedestrian: a pedestrian (it has the right of way: the robot passes in front of it
            only if it cannot stay behind).
        pass_margin: the robot must be past it `pass_margin_steps` before it arrives (False:
            only while it is on the path, e.g. a car the robot merges in front of, whose
            s_front_m already allows for it; agents/robot/right_of_way.py).
    """

    occupied: np.ndarray
    s_rear_m: np.ndarray
    s_front_m: np.ndarray
    k_first: int
    k_last: int
    is_pedestrian: bool = False
    pass_margin: bool = True


def occupied_spans(occupied: np.ndarray, rows: np.ndarray | None = None
                   ) -> list[tuple[int, int, int]]:
    """(row, first step, last step) of the rows of occupied (P, N) bool with a True, in order.

    Every row's first and last True at once (not a flatnonzero per row).

    Args:
        occupied: (P, N) bool, per object and plan step.
        rows: (P,) bool, the rows to look at (None: every one; a row without a True is left
            out either way).
    """
    some = occupied.any(axis=1)
    index = np.flatnonzero(some if rows is None else some & rows)
    if not len(index):
        return []
    picked = occupied[index]
    first = picked.argmax(axis=1)
    last = picked.shape[1] - 1 - picked[:, ::-1].argmax(axis=1)
    return list(zip(index.tolist(), first.tolist(), last.tolist()))


class Clearances(NamedTuple):
    """The lateral clearances of the robot's corridor, added to each side of its width [m].

    Attributes:
        lateral_m: to anything.
        pedestrian_closing_m: a pedestrian heading for the corridor (its distance to the route
            shrinking) is in the way already within this clearance (None: lateral_m).
        pedestrian_m: the clearance to any pedestrian, also one walking away (None: lateral_m).
    """

    lateral_m: float
    pedestrian_closing_m: float | None = None
    pedestrian_m: float | None = None


def objects_on_path(route: Route, scene: ScenePrediction, s0: float, robot_length_m: float,
                    robot_width_m: float, clearances: Clearances,
                    mask: np.ndarray | None = None) -> list[list[PathObject]]:
    """Per hypothesis, the predicted objects that occupy the robot's corridor.

    Args:
        route: the robot's route.
        scene: L hypotheses, M objects, N plan steps.
        s0: the robot's arc length (its footprint centre) [m].
        robot_length_m: the robot's length [m].
        robot_width_m: the robot's width [m].
        clearances: the corridor's clearances beside the robot's width.
        mask: (L, M) bool, the objects of each hypothesis to look at, in place of scene.mask
            (None: scene.mask).

    Returns:
        L lists of PathObject.
    """
    lateral_margin_m, pedestrian_margin_m, pedestrian_clearance_m = clearances
    mask = scene.mask if mask is None else mask
    n_hyp, n_obj = mask.shape
    if n_obj == 0 or not mask.any():
        return [[] for _ in range(n_hyp)]
    kernels = corridor_kernels()
    # project each distinct prediction once: an object present in several hypotheses and
    # predicted alike in every one (a tracked one) from the first, the others where present
    # (corridor_kernels.distinct_predictions; numpy reference:
    # tests/agents/test_corridor_kernels.py)
    shared = np.empty(n_obj, dtype=bool)
    pair = np.empty((n_hyp, n_obj), dtype=np.int64)  # (L, M) the pair standing for each
    source = np.empty((2, n_hyp * n_obj), dtype=np.int64)
    n_pair = kernels.distinct_predictions(
        (scene.xy, scene.heading, scene.length_m, scene.width_m, scene.is_pedestrian), mask,
        (shared, pair, source))
    # the footprints' corners projected on the route, their extents: one compiled pass
    # (sim/route_kernels.project_footprints; its numpy reference: tests/sim/test_route_kernels.py)
    heading = scene.heading[source[0, :n_pair], source[1, :n_pair]]  # (P, N)
    extent = np.empty((5,) + heading.shape)  # (5, P, N)
    route_kernels().project_footprints(scene.xy, np.cos(heading), np.sin(heading),
                                       scene.length_m, scene.width_m, source,
                                       route.kernel_segment_table, extent)
    # in the corridor: the lateral extent overlaps the robot's width plus the clearance (a
    # pedestrian heading for the corridor, its distance to the route shrinking, is in the way
    # from further out: it has the right of way on the carriageway; one standing or walking
    # away is not), and the projection is not clamped at the route's ends; relevant: not
    # beside or behind the robot now (its rear short of the robot's front: not the robot's to
    # yield to; a car alongside that drifts into the corridor in its prediction is one)
    # (corridor_kernels.corridor_occupancy; numpy reference: tests/agents/test_corridor_kernels.py)
    clearance = lateral_margin_m if pedestrian_clearance_m is None else pedestrian_clearance_m
    widen = pedestrian_margin_m is not None
    occupied = np.empty(heading.shape, dtype=bool)  # (P, N)
    span = np.empty((n_pair, 3), dtype=np.int64)  # (P, 3) first, last occupied step, kind
    listed = np.empty((n_hyp, n_obj), dtype=np.int64)  # (L, M) each one's relevant pairs
    n_listed = np.empty(n_hyp, dtype=np.int64)  # (L,) how many
    half = 0.5 * robot_width_m
    n_relevant = kernels.corridor_occupancy(
        extent, scene.is_pedestrian, source,
        (half + clearance, half + lateral_margin_m, widen,
         half + pedestrian_margin_m if widen else 0.0, route.length_m, s0 + 0.5 * robot_length_m),
        mask, pair, (occupied, span, listed, n_listed))
    if not n_relevant:
        return [[] for _ in range(n_hyp)]
    s_rear, s_front = extent[0], extent[1]  # (P, N) each
    objects = {i: PathObject(occupied[i], s_rear[i], s_front[i], first, last, bool(ped))
               for i, (first, last, ped) in enumerate(span.tolist()) if first >= 0}
    out: list[list[PathObject]] = [[] for _ in range(n_hyp)]
    for l, count in enumerate(n_listed.tolist()):
        if count:
            out[l] = [objects[i] for i in listed[l, :count].tolist()]
    return out


def static_outlines(polygons) -> np.ndarray:
    """(S, P, 2) the outline points of S static polygons: vertices and edge midpoints [m].

    Each polygon (V, 2) gives its V vertices and V edge midpoints; shorter outlines are
    padded with their first vertex (P = 2 max V). (0, 0, 2) without polygons.
    """
    outlines = []
    for poly in polygons:
        poly = np.asarray(poly, dtype=np.float64)
        outlines.append(np.concatenate([poly, 0.5 * (poly + np.roll(poly, -1, axis=0))]))
    if not outlines:
        return np.zeros((0, 0, 2))
    width = max(len(o) for o in outlines)
    return np.stack([np.concatenate([o, np.repeat(o[:1], width - len(o), axis=0)])
                     for o in outlines])


@dataclass(frozen=True)
class StaticObstacles:
    """Static polygons projected on a route once (they do not move): `limit` per step.

    Attributes:
        s_min: (S,) smallest arc length of each polygon's outline points [m].
        s_max: (S,) largest [m].
        in_corridor: (S,) bool, the polygon reaches into the corridor laterally (and lies
            along the route, not beyond its ends).
    """

    s_min: np.ndarray
    s_max: np.ndarray
    in_corridor: np.ndarray

    @classmethod
    def project(cls, route: Route, outlines: np.ndarray | None, robot_width_m: float,
                lateral_margin_m: float) -> StaticObstacles:
        """Project (S, P, 2) outline points (static_outlines) [m] (or None) onto `route`.

        A polygon is in the corridor when its outline points' lateral offsets reach
        [-(w/2 + margin), w/2 + margin] (w the robot's width): the polygon's own points, not
        its bounding box, whose corners lie off a polygon not aligned with the axes (a
        building beside a diagonal street).

        Args:
            route: the robot's route.
            outlines: (S, P, 2) the static polygons' outline points [m], or None.
            robot_width_m: the robot's width [m].
            lateral_margin_m: clearance added to each side of the robot's width [m].
        """
        if outlines is None or len(outlines) == 0:
            return cls(np.zeros(0), np.zeros(0), np.zeros(0, bool))
        s, lateral, _ = route.project(outlines)
        half = 0.5 * robot_width_m + lateral_margin_m
        s_min, s_max = s.min(axis=-1), s.max(axis=-1)
        inside = ((lateral.min(axis=-1) <= half) & (lateral.max(axis=-1) >= -half)
                  & (s_min < route.length_m) & (s_max > 0.0))
        return cls(s_min, s_max, inside)

    def limit(self, s0: float, robot_length_m: float) -> float:
        """Arc length of the nearest polygon ahead of the robot at s0 [m] in its corridor (inf)."""
        ahead = self.in_corridor & (self.s_max >= s0 - 0.5 * robot_length_m)
        return float(self.s_min[ahead].min()) if ahead.any() else np.inf


def static_limit(route: Route, outlines: np.ndarray | None, s0: float, robot_length_m: float,
                 robot_width_m: float, lateral_margin_m: float) -> float:
    """Arc length of the nearest static polygon ahead that reaches into the corridor (inf) [m].

    Args:
        route: the robot's route.
        outlines: (S, P, 2) the static polygons' outline points (static_outlines) [m], or None.
        s0: the robot's arc length [m].
        robot_length_m: the robot's length [m].
        robot_width_m: the robot's width [m].
        lateral_margin_m: clearance added to each side of the robot's width [m].
    """
    return StaticObstacles.project(route, outlines, robot_width_m, lateral_margin_m).limit(
        s0, robot_length_m)


def route_curvature(route: Route) -> tuple[np.ndarray, np.ndarray]:
    """Curvature at the route's inner vertices: (V,) arc lengths [m] and (V,) |kappa| [1/m]."""
    seg = np.diff(route.points, axis=0)
    seg_len = np.linalg.norm(seg, axis=1)
    heading = np.unwrap(np.arctan2(seg[:, 1], seg[:, 0]))
    if len(seg) < 2:
        return np.zeros(0), np.zeros(0)
    turn = np.abs(np.diff(heading))
    kappa = turn / (0.5 * (seg_len[1:] + seg_len[:-1]))
    return np.cumsum(seg_len)[:-1], kappa


def curvature_speed_bound(vertex_s: np.ndarray, vertex_kappa: np.ndarray, s_lo: np.ndarray,
                          s_hi: np.ndarray, window_m: float, lat_accel_max_mps2: float,
                          v_cap_mps: float = np.inf) -> tuple[np.ndarray, bool]:
    """(N,) v <= min(v_cap, sqrt(a_lat / kappa)) over the positions a step may have [m/s].

    Args:
        vertex_s: (V,) arc lengths of the route's vertices [m].
        vertex_kappa: (V,) their curvatures [1/m].
        s_lo: (N,) smallest arc length each plan step may reach [m].
        s_hi: (N,) largest arc length each plan step may reach [m].
        window_m: vertices this far outside [s_lo, s_hi] count too (the footprint's extent) [m].
        lat_accel_max_mps2: the lateral acceleration allowed [m/s^2].
        v_cap_mps: the speed cap [m/s] (inf: none).

    Returns:
        the (N,) bounds [m/s] and whether a curve bounds the speed at some step (its bound
        finite, before the cap).
    """
    out = np.empty(len(s_lo))
    if len(vertex_kappa) == 0:  # straight: np.minimum(inf, v_cap)
        out[:] = v_cap_mps
        return out, False
    # the largest curvature near each step, its bound, capped: one compiled pass
    # (corridor_kernels.curvature_speed_bound; numpy reference: tests/agents/
    # test_corridor_kernels.py)
    curved = corridor_kernels().curvature_speed_bound(
        np.asarray(vertex_s, dtype=np.float64), np.asarray(vertex_kappa, dtype=np.float64),
        np.asarray(s_lo, dtype=np.float64), np.asarray(s_hi, dtype=np.float64),
        float(window_m), float(lat_accel_max_mps2), float(v_cap_mps), out)
    return out, bool(curved)


def mode_bounds(objects: list[PathObject], modes: tuple[str, ...], n_steps: int, s0: float,
                robot_length_m: float, gap_m: float, pass_margin_steps: int,
                pedestrian_gap_m: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Bounds on the robot's progress (relative to s0) for one branch and one choice of modes.

    Args:
        objects: the branch's PathObjects.
        modes: one of BEHIND / PAST per object.
        n_steps: N plan steps.
        s0: the robot's arc length [m].
        robot_length_m: the robot's length [m].
        gap_m: the longitudinal gap kept to an object [m].
        pass_margin_steps: the robot is past an object this many steps before it arrives.
        pedestrian_gap_m: the gap kept to a pedestrian (default gap_m) [m].

    Returns:
        s_low (N,) and s_up (N,) [m]: s_low <= s <= ... and s + h v <= s_up.
    """
    s_low, s_up = np.empty(n_steps), np.empty(n_steps)
    s_low[:], s_up[:] = -np.inf, np.inf
    half = 0.5 * robot_length_m
    for obj, mode in zip(objects, modes):
        k0, k1 = obj.k_first, obj.k_last
        gap = gap_m if pedestrian_gap_m is None or not obj.is_pedestrian else pedestrian_gap_m
        if mode == BEHIND:  # min(s_up, inf) elsewhere leaves it as it is
            steps = slice(k0, k1 + 1)
            np.minimum(s_up[steps], obj.s_rear_m[steps] - gap - half - s0, out=s_up[steps])
        else:
            need = np.full(n_steps, -np.inf)
            need[k0:k1 + 1] = obj.s_front_m[k0:k1 + 1] + gap + half - s0
            start = max(0, k0 - pass_margin_steps) if obj.pass_margin else k0
            need[start:k0] = need[k0]
            s_low = np.maximum(s_low, np.maximum.accumulate(need))
    return s_low, s_up


def full_acceleration_progress(v0: float, v_cap_mps: float, accel_max_mps2: float,
                               dt_s: float, n_steps: int,
                               v_max_mps: np.ndarray | None = None) -> np.ndarray:
    """(N,) the progress of full acceleration under the steps' speed bounds [m].

    v_k = min(v_k-1 + a dt, v_max_k, v_cap), v >= 0, the progress the sum of
    0.5 (v_k-1 + v_k) dt (past_reachable's test of an object without a pass margin).

    Args:
        v0: the robot's speed [m/s].
        v_cap_mps: its speed cap [m/s].
        accel_max_mps2: its largest acceleration [m/s^2].
        dt_s: plan step [s].
        n_steps: N plan steps.
        v_max_mps: (N,) the speed bound of each plan step [m/s] (None: v_cap only).
    """
    t = dt_s * np.arange(1, n_steps + 1)
    cap = (np.full(n_steps, v_cap_mps) if v_max_mps is None
           else np.minimum(v_max_mps, v_cap_mps))
    v = accel_max_mps2 * t + np.minimum(v0, np.minimum.accumulate(cap - accel_max_mps2 * t))
    v = np.maximum(v, 0.0)
    return np.cumsum(0.5 * (np.concatenate([[v0], v[:-1]]) + v) * dt_s)


def past_reachable(obj: PathObject, v0: float, v_cap_mps: float, accel_max_mps2: float,
                   dt_s: float, ahead_m: float, pass_margin_steps: int,
                   full_progress_m: np.ndarray | None = None) -> bool:
    """Whether full acceleration (capped at v_cap) gets the robot past `obj` in time.

    Args:
        obj: the object.
        v0: the robot's speed [m/s].
        v_cap_mps: its speed cap [m/s].
        accel_max_mps2: its largest acceleration [m/s^2].
        dt_s: plan step [s].
        ahead_m: how far the robot's progress must be beyond the object's front: the
            longitudinal gap kept + half the robot's length - its arc length now [m].
        pass_margin_steps: as in mode_bounds.
        full_progress_m: (N,) full_acceleration_progress of v0, v_cap, accel_max, dt_s and
            the plan steps' speed bounds (e.g. its curves) [m]; needed for an object without
            a pass margin (None: the speed bounds are v_cap alone).
    """
    t_cap = max(0.0, (v_cap_mps - v0) / accel_max_mps2)

    def reach(t):
        if t <= t_cap:
            return v0 * t + 0.5 * accel_max_mps2 * t * t
        return v0 * t_cap + 0.5 * accel_max_mps2 * t_cap ** 2 + max(v0, v_cap_mps) * (t - t_cap)

    ahead = ahead_m
    if not obj.pass_margin:
        # past it at every step it is on the path (its front there may keep moving ahead),
        # accelerating fully under the steps' speed bounds: v_k = min(v_k-1 + a dt, v_max_k)
        s = (full_acceleration_progress(v0, v_cap_mps, accel_max_mps2, dt_s,
                                        len(obj.s_front_m), None)
             if full_progress_m is None else full_progress_m)
        k = slice(obj.k_first, obj.k_last + 1)
        return bool(np.all(s[k] >= obj.s_front_m[k] + ahead))
    k = obj.k_first - pass_margin_steps
    if k < 0:
        return False
    return reach((k + 1) * dt_s) >= obj.s_front_m[obj.k_first] + ahead


def reachable_progress(v0: float, prev_accel: float, accel_max_mps2: float,
                       jerk_max_mps3: float, first_dt_s: float, dt_s: float,
                       v_max_mps: np.ndarray) -> np.ndarray:
    """(N,) an upper bound on the progress at the end of each plan step [m].

    The plan's dynamics (agents/robot/qp.py) with the acceleration as high as the jerk bound
    lets it climb from the previous command (within first_dt_s on the first step, dt_s on each
    next one), at most accel_max, and the speed capped by v_max at the end of each step:
    v_k <= min(v_max_k, v_{k-1} + a_k dt) and s_k - s_{k-1} = dt (v_{k-1} + v_k) / 2.

    Args:
        v0: the robot's speed [m/s].
        prev_accel: its previous acceleration command [m/s^2].
        accel_max_mps2: its largest acceleration [m/s^2].
        jerk_max_mps3: the jerk bound [m/s^3].
        first_dt_s: the time the first acceleration may change in (a simulator step) [s].
        dt_s: plan step [s].
        v_max_mps: (N,) the speed bound of each plan step [m/s].
    """
    # v_k = min(v0 + climb_k, min_{j <= k} v_max_j + climb_k - climb_j), and v >= 0, climb
    # the sum of the accelerations times dt: one compiled pass (corridor_kernels.
    # reachable_progress; its numpy reference: tests/agents/test_corridor_kernels.py)
    out = np.empty(len(v_max_mps))
    corridor_kernels().reachable_progress(
        float(v0), float(prev_accel), float(accel_max_mps2), float(jerk_max_mps3),
        float(first_dt_s), float(dt_s), np.asarray(v_max_mps, dtype=np.float64), out)
    return out


def provably_infeasible(s_low: np.ndarray, s_up: np.ndarray, reachable_m: np.ndarray,
                        margin_m: float) -> bool:
    """Whether no plan meets progress bounds by less than margin_m of violation.

    Progress never decreases (v >= 0), so a plan past s_low[k] at step k is past it at every
    later step j, where it must also be behind s_up[j] (s_up bounds s + h v, h v >= 0) and
    within reach (reachable_progress).

    Args:
        s_low: (L, N) lower bounds on progress (-inf: none) [m].
        s_up: (L, N) upper bounds on progress + headway x speed (inf: none) [m].
        reachable_m: (N,) the upper bound on progress of reachable_progress [m].
        margin_m: the violation that still does not count as infeasible [m].
    """
    # np.maximum.accumulate(s_low) > np.minimum(s_up, reachable_m) + margin_m anywhere, in one
    # compiled pass (corridor_kernels.progress_infeasible; numpy reference: tests/agents/
    # test_corridor_kernels.py)
    return bool(corridor_kernels().progress_infeasible(
        np.asarray(s_low, dtype=np.float64), np.asarray(s_up, dtype=np.float64),
        np.asarray(reachable_m, dtype=np.float64), float(margin_m)))
