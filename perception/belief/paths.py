"""A tracked car's path, inferred from its track and the static map's lanes (never its name).

The robot knows the lanes of the map, not where each other car is going: a tracked vehicle
drives along the lane whose centre line is nearest to it (within the lane's half width plus
LANE_MATCH_MARGIN_M) and whose heading matches the track's heading (within
LANE_MATCH_HEADING_RAD). Its path is that lane followed by the lane's continuation: a lane
that starts where it ends (within LANE_JOIN_M, heading within LANE_MATCH_HEADING_RAD), as long
as there is exactly one (a left-turn-only lane continues into its turn; up to
MAX_CHAINED_LANES lanes). Where a lane branches into several, the path ends with the lane (the
car's choice would be one more hypothesis).
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from marl_social.perception.belief import compiled
from marl_social.sim.road_map import RoadMap, Route
from marl_social.sim.signal_rules import route_signal_lines

LANE_MATCH_MARGIN_M = 0.5  # a car this far outside a lane's edges still drives in it [m]
LANE_MATCH_HEADING_RAD = math.radians(45.0)  # largest track-to-lane heading difference [rad]
LANE_JOIN_M = 0.5  # a lane starting this close to another's end continues it [m]
MAX_CHAINED_LANES = 4  # a car's path follows at most this many lanes
ROUTE_MEMO_SIZE = 256  # route_of remembers this many recent queries (a step's tracks, twice)
_SAME_POINT_M = 1e-6  # a continuation's first point this close to the end is the same point [m]


def _angle_diff(a, b):
    """Wrapped difference a - b of angles [rad], in [-pi, pi)."""
    return (a - b + np.pi) % (2.0 * np.pi) - np.pi


def route_pose(route: Route, s: float) -> tuple[float, float, float]:
    """`route.point_at(s)` of one arc length s [m] on Python floats: x, y [m], heading [rad].

    The same segment lookup (searchsorted side="right", clamped to the segments) and the same
    arithmetic as Route.point_at / Route.point_at_float, bit for bit, without numpy's per-call
    cost (the belief asks it for every tracked human every step). Reads the route's segment
    tables (Route.vertex_s_list, segment_heading_rad), as models/gap_evaluation reads its pose
    table.
    """
    x, y = route.point_at_float(s)
    return x, y, route_heading(route, s)


def route_heading(route: Route, s: float) -> float:
    """`route.point_at(s)`'s heading [rad] of one arc length s [m], as a Python float.

    Route.point_at's segment (searchsorted side="right" in the route's cumulative arc lengths,
    clamped to the segments), found with bisect (`route_pose`).
    """
    cum_s = route.vertex_s_list
    n_seg = len(cum_s) - 1
    k = 0 if n_seg == 1 else min(max(bisect.bisect_right(cum_s, s) - 1, 0), n_seg - 1)
    return float(route.segment_heading_rad[k])


class LanePaths:
    """The map's lanes as routes, and the path a tracked car drives along.

    Args:
        road_map: the static map (its lanes).

    Attributes:
        successors: per lane, the indices of the lanes that continue it.
        routes: per lane, the Route of the lane followed by its unique continuations.

    `route_of` remembers its recent answers (the hidden-agent and the phase beliefs ask about
    the same tracks each step) and `signal_lines` its per-route answers (static).
    """

    def __init__(self, road_map: RoadMap):
        """Turn every lane's centre line into a Route and chain each lane's continuations."""
        lanes = road_map.lanes
        self._lanes = [Route(lane.centerline, f"lane_{i}") for i, lane in enumerate(lanes)]
        self._half_width_m = [0.5 * lane.width_m for lane in lanes]
        self.successors = self._find_successors(lanes)
        self.routes = [self._chained(i, lanes) for i in range(len(lanes))]
        self._route_memo: dict[tuple, Route | None] = {}
        self._signal_lines: dict[tuple, tuple] = {}
        # every lane's segments for view_kernels.lane_projections: (S, 6) start x, y [m],
        # unit direction x, y, length [m] and arc length at the start [m], lane by lane
        self._segments = np.vstack([np.column_stack([
            lane.segment_start_m, lane.segment_direction, lane.segment_length_m,
            lane.vertex_s_m[:-1]])
            for lane in self._lanes]) if lanes else np.zeros((0, 6))
        self._first_segment = np.cumsum([0] + [lane.n_segments for lane in self._lanes])

    @staticmethod
    def _find_successors(lanes) -> list[list[int]]:
        """Per lane, the lanes starting at its end with a matching heading."""
        if not lanes:
            return []
        starts = np.array([lane.centerline[0] for lane in lanes])
        ends = np.array([lane.centerline[-1] for lane in lanes])
        first = np.array([lane.centerline[1] - lane.centerline[0] for lane in lanes])
        last = np.array([lane.centerline[-1] - lane.centerline[-2] for lane in lanes])
        heading_in = np.arctan2(first[:, 1], first[:, 0])
        heading_out = np.arctan2(last[:, 1], last[:, 0])
        gap = np.linalg.norm(ends[:, None, :] - starts[None, :, :], axis=-1)  # (from, to)
        turn = np.abs(_angle_diff(heading_in[None, :], heading_out[:, None]))
        joins = (gap <= LANE_JOIN_M) & (turn <= LANE_MATCH_HEADING_RAD)
        np.fill_diagonal(joins, False)
        return [np.flatnonzero(row).tolist() for row in joins]

    def _chained(self, i: int, lanes) -> Route:
        """Lane i's route followed by its unique continuations (lane i's own Route if none)."""
        chain = [i]
        while len(chain) < MAX_CHAINED_LANES:
            nxt = self.successors[chain[-1]]
            if len(nxt) != 1 or nxt[0] in chain:
                break
            chain.append(nxt[0])
        if len(chain) == 1:
            return self._lanes[i]
        points = [lanes[i].centerline]
        for j in chain[1:]:
            pts = lanes[j].centerline
            if np.linalg.norm(pts[0] - points[-1][-1]) <= _SAME_POINT_M:
                pts = pts[1:]
            points.append(pts)
        return Route(np.vstack(points), "lane_" + "+".join(str(j) for j in chain))

    def route_of(self, xy, heading_rad: float) -> Route | None:
        """The path of a car at xy (2,) [m] heading heading_rad [rad]: its lane and onward.

        None if no lane matches (off the road, or driving against every lane).
        """
        x, y = float(xy[0]), float(xy[1])
        key = (x, y, float(heading_rad))
        if key in self._route_memo:
            return self._route_memo[key]
        if len(self._route_memo) >= ROUTE_MEMO_SIZE:
            self._route_memo.clear()
        route = self._route_of(x, y, key[2])
        self._route_memo[key] = route
        return route

    def _route_of(self, x: float, y: float, heading_rad: float) -> Route | None:
        """`route_of` computed (see there).

        Each lane's project_point, for a finite point all at once (belief_kernels.
        lane_projections, the same arithmetic); the lanes in order, the first closest that
        matches kept.
        """
        if math.isfinite(x) and math.isfinite(y) and self._lanes:
            s_all, lateral_all = compiled.view().lane_projections(
                x, y, self._segments, self._first_segment)
            projections = zip(s_all.tolist(), lateral_all.tolist())
        else:
            projections = (lane.project_point(x, y) for lane in self._lanes)
        best, best_offset = None, math.inf
        for k, ((s, lateral), half) in enumerate(zip(projections, self._half_width_m)):
            if abs(lateral) > half + LANE_MATCH_MARGIN_M or abs(lateral) >= best_offset:
                continue
            lane_heading = route_heading(self._lanes[k], s)
            diff = (heading_rad - lane_heading + math.pi) % (2.0 * math.pi) - math.pi
            if abs(diff) <= LANE_MATCH_HEADING_RAD:
                best, best_offset = self.routes[k], abs(lateral)
        return best

    def signal_lines(self, route: Route, road_map: RoadMap) -> tuple[np.ndarray, np.ndarray]:
        """sim.signal_rules.route_signal_lines(route, road_map), once per (route, map).

        Returns read-only arrays: s (S,) [m] and head (S,) int.
        """
        key = (id(route), id(road_map))
        cached = self._signal_lines.get(key)
        if cached is None or cached[0] is not route or cached[1] is not road_map:
            lines, heads = route_signal_lines(route, road_map)
            lines.setflags(write=False)
            heads.setflags(write=False)
            cached = self._signal_lines[key] = (route, road_map, (lines, heads))
        return cached[2]
