"""What the static map imposes along a route: stop lines, right of way, curve speeds.

Everything here is read from the static map (which every agent knows, like an HD map) and the
driver's own route, plus, for the right of way, the driver's own tracks:

* stop lines (`StopLine` of kind "stop_sign") the route crosses, as arc lengths: the driver must
  come to rest before its front passes one, then may go (`stop_line_positions`);
* conflict zones the route passes, with the arc lengths where it enters and leaves them and
  whether the driver yields there: it yields unless its route enters the zone along one of the
  zone's priority lanes (`route_conflicts`);
* which tracked objects have the right of way in a zone: those travelling along one of its
  priority lanes (`priority_mask`);
* the curve speed the route allows: v <= sqrt(a_lat / kappa) (`CurveSpeed`).

The human drivers (agents/human.py) turn these into their Q* (models/driver.py, `RoadRules`):
the stop line and the curve speed are constraints, the right of way a cost (the conflict term
of sim/costs.py). A robot planner gets the same facts from the same functions:
`route_conflicts(route, road_map)` and `stop_line_positions(route, road_map)`; the metrics
(metrics/physical.py) use them to tell who had the right of way.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from marl_social.sim.kernel_cache import route_kernels
from marl_social.sim.road_map import ConflictZone, Lane, RoadMap, Route

LANE_HEADING_TOLERANCE_RAD = math.radians(35.0)  # heading within this of a lane's = along it
LANE_LATERAL_MARGIN_M = 0.25  # a centre this far beyond half a lane width still counts [m]
ROUTE_SAMPLE_STEP_M = 0.25  # route sampling step to find where it enters a zone [m]
CURVE_PROFILE_STEP_M = 0.5  # grid step of the curve-speed profile along a route [m]


@dataclass(frozen=True)
class RouteConflict:
    """A conflict zone on a route.

    Attributes:
        zone_index: index into RoadMap.conflict_zones.
        zone: the zone.
        s_enter_m: arc length at which the route's centre line enters the zone [m].
        s_exit_m: arc length at which it leaves it (the last sample inside) [m].
        yields: the route enters the zone on none of its priority lanes, so a driver on it
            gives way to the traffic on them.
    """

    zone_index: int
    zone: ConflictZone
    s_enter_m: float
    s_exit_m: float
    yields: bool


def _lane_routes(lanes: tuple[Lane, ...]) -> list[Route]:
    return [_lane_route(lane, lane.name or f"lane {i}") for i, lane in enumerate(lanes)]


def _lane_route(lane: Lane, name: str) -> Route:
    """The Route along a lane's centreline, built once per centreline (a static-map table)."""
    points = np.ascontiguousarray(lane.centerline, dtype=np.float64)
    return _cached_route(points.tobytes(), points.shape, name)


@functools.lru_cache(maxsize=256)
def _cached_route(points: bytes, shape: tuple, name: str) -> Route:
    return Route(np.frombuffer(points, dtype=np.float64).reshape(shape).copy(), name)


def on_lanes(lanes, xy, heading) -> np.ndarray:
    """Whether objects travel along any of the given lanes.

    An object is on a lane when its centre is within half the lane width (plus
    LANE_LATERAL_MARGIN_M) of the centreline, between the centreline's ends, and its heading is
    within LANE_HEADING_TOLERANCE_RAD of the lane's direction there.

    In one compiled call (sim/route_kernels.on_lanes; its numpy reference:
    tests/reference/lane_test.py).

    Args:
        lanes: the lanes (Lane).
        xy: (M, 2) object centres [m].
        heading: (M,) object headings [rad], or one heading for all.

    Returns:
        (M,) bool.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    heading = np.asarray(heading, dtype=np.float64).reshape(-1)
    lanes = tuple(lanes)
    if not lanes:
        return np.zeros(len(xy), dtype=bool)
    if heading.shape != (len(xy),):
        heading = np.broadcast_to(heading, (len(xy),))
    segments, lane_table = _lane_table(lanes)
    out = np.empty(len(xy), dtype=bool)
    route_kernels().on_lanes(np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1]),
                             np.ascontiguousarray(heading), segments, lane_table,
                             LANE_HEADING_TOLERANCE_RAD, out)
    return out


# ids of the lanes -> (those lanes, their `_lane_table`); emptied at _MAX_LANE_TABLES entries
_MAX_LANE_TABLES = 256
_LANE_TABLES: dict[tuple, tuple] = {}


def _lane_table(lanes: tuple[Lane, ...]) -> tuple[np.ndarray, ...]:
    """What route_kernels.on_lanes takes of the lanes, built once per tuple of the same lanes.

    The static map's lanes (its zones' priority lanes) are the same objects at every call.

    Returns:
        (7, S) their centrelines' segments one lane after the other
        (Route.kernel_segment_table's six rows, then the segments' headings [rad]) and (3, N)
        per lane the end column of its segments, its centreline's length [m] and half its
        width plus LANE_LATERAL_MARGIN_M [m].
    """
    key = tuple(id(lane) for lane in lanes)
    hit = _LANE_TABLES.get(key)
    if hit is not None and all(a is b for a, b in zip(hit[0], lanes)):
        return hit[1]
    routes = _lane_routes(lanes)
    table = (np.ascontiguousarray(np.vstack([
                 np.hstack([r.kernel_segment_table for r in routes]),
                 np.concatenate([r.segment_heading_rad for r in routes])])),
             np.array([np.cumsum([r.n_segments for r in routes]),
                       [r.length_m for r in routes],
                       [0.5 * lane.width_m + LANE_LATERAL_MARGIN_M for lane in lanes]],
                      dtype=np.float64))
    if len(_LANE_TABLES) >= _MAX_LANE_TABLES:
        _LANE_TABLES.clear()
    _LANE_TABLES[key] = (lanes, table)
    return table


def priority_mask(zone: ConflictZone, road_map: RoadMap, xy, heading) -> np.ndarray:
    """(M,) bool: the objects that have the right of way in `zone` (on one of its priority lanes).

    Args:
        zone: the conflict zone.
        road_map: the static map (its lanes).
        xy: (M, 2) object centres [m] (e.g. a driver's tracks).
        heading: (M,) object headings [rad].
    """
    lanes = [road_map.lanes[i] for i in zone.priority_lanes]
    return on_lanes(lanes, xy, heading)


def route_conflicts(route: Route, road_map: RoadMap) -> tuple[RouteConflict, ...]:
    """The conflict zones a route passes, in the order it reaches them.

    Args:
        route: the driver's route.
        road_map: the static map (its conflict zones and lanes).

    Returns:
        One RouteConflict per zone the route's centre line passes through.
    """
    n = max(2, math.ceil(route.length_m / ROUTE_SAMPLE_STEP_M) + 1)
    s = np.linspace(0.0, route.length_m, n)
    xy, heading = route.point_at(s)
    found = []
    for k, zone in enumerate(road_map.conflict_zones):
        inside = np.flatnonzero(zone.contains(xy))
        if not len(inside):
            continue
        first = inside[0]
        lanes = [road_map.lanes[i] for i in zone.priority_lanes]
        yields = not bool(on_lanes(lanes, xy[first:first + 1], heading[first:first + 1])[0])
        found.append(RouteConflict(k, zone, float(s[first]), float(s[inside[-1]]), yields))
    return tuple(sorted(found, key=lambda c: c.s_enter_m))


def stop_line_positions(route: Route, road_map: RoadMap, kind: str = "stop_sign") -> np.ndarray:
    """(S,) ascending arc lengths [m] at which the route crosses the map's stop lines of `kind`.

    Args:
        route: the driver's route.
        road_map: the static map (its stop lines).
        kind: "stop_sign" or "signal".
    """
    found = [route.segment_crossings(line.segment) for line in road_map.stop_lines
             if line.kind == kind]
    return np.unique(np.concatenate(found)) if found else np.zeros(0)


class CurveSpeed:
    """The curve speed a route allows, v <= sqrt(a_lat / kappa), on a grid along it.

    The curvature at an arc length is the largest at the route's vertices within half a
    footprint (`window_m`) of it, so a car slows before its front enters a bend.

    Args:
        route: the route.
        lat_accel_mps2: the lateral acceleration the driver accepts [m/s^2], > 0.
        window_m: how far ahead and behind a vertex's curvature counts [m].
    """

    def __init__(self, route: Route, lat_accel_mps2: float, window_m: float):
        if not lat_accel_mps2 > 0:
            raise ValueError(f"CurveSpeed: lat_accel_mps2 must be > 0, got {lat_accel_mps2}")
        seg = np.diff(route.points, axis=0)
        seg_len = np.linalg.norm(seg, axis=1)
        heading = np.unwrap(np.arctan2(seg[:, 1], seg[:, 0]))
        vertex_s = np.cumsum(seg_len)[:-1]  # (V,) inner vertices
        kappa = np.abs(np.diff(heading)) / (0.5 * (seg_len[1:] + seg_len[:-1]))
        grid = np.arange(0.0, route.length_m + CURVE_PROFILE_STEP_M, CURVE_PROFILE_STEP_M)
        near = np.abs(grid[:, None] - vertex_s[None, :]) <= window_m  # (G, V)
        k_max = np.where(near, kappa[None, :], 0.0).max(axis=1, initial=0.0)
        with np.errstate(divide="ignore"):
            self.v_max_mps = np.sqrt(lat_accel_mps2 / k_max)  # (G,), inf where straight
        self.is_straight = not bool(np.any(k_max > 1e-9))

    def at(self, s_m) -> np.ndarray:
        """(...) the speed cap [m/s] at arc lengths (...) [m] (inf on straight stretches)."""
        k = np.rint(np.asarray(s_m) / CURVE_PROFILE_STEP_M).astype(np.int64)
        return self.v_max_mps[np.minimum(np.maximum(k, 0), len(self.v_max_mps) - 1)]
