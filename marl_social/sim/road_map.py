"""Static map: lanes, routes (reference paths), crosswalks, stop lines, conflict zones, obstacles.

The static map is what every agent knows in advance (like an HD map): planners may read it, the
world's dynamic state they may not. All coordinates are metres in the world frame, angles are
radians counter-clockwise from +x.
"""

from __future__ import annotations

import bisect
import copy
import math
from dataclasses import dataclass, field

import numpy as np

from marl_social.sim.kernel_cache import route_kernels
from marl_social.sim.signals import SignalHead, SignalPlan

PROJECT_POINT_LOOP_MAX = 5  # Route.project_point loops in Python up to this many segments (then a
# call of the compiled `project` costs less; either gives the same bits)

def _as_polyline(points, name: str) -> np.ndarray:
    """Validate a polyline given as (P, 2) points, P >= 2, finite, no zero-length segment."""
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 2:
        raise ValueError(f"{name}: expected a polyline of shape (P>=2, 2), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: polyline has non-finite coordinates")
    if np.any(np.linalg.norm(np.diff(arr, axis=0), axis=1) <= 1e-9):
        raise ValueError(f"{name}: polyline has a zero-length segment")
    return arr


class Route:
    """A reference path as a polyline with arc length.

    Args:
        points: (P, 2) vertices [m], in travel order.
        name: used in error messages.

    Attributes (read only; the compiled kernels and the belief's fast paths take these tables):
        segment_start_m, segment_direction: (S, 2) each segment's start [m] and unit direction;
        segment_length_m, segment_heading_rad: (S,) its length [m] and heading [rad];
        vertex_s_m: (S + 1,) arc length at each vertex [m] (vertex_s_list: the same, a list);
        kernel_segment_table: (6, S) start x, y, direction x, y, length, arc length at start;
        segment_pose_table: (S, 6) start x, y, direction x, y, cos and sin of the heading.
    """

    def __init__(self, points, name: str = "route"):
        self.points = _as_polyline(points, name)
        self.name = name
        seg = np.diff(self.points, axis=0)
        self.segment_start_m = self.points[:-1]
        self._seg_vec = seg
        self.segment_length_m = np.linalg.norm(seg, axis=1)
        self.segment_direction = seg / self.segment_length_m[:, None]
        self.segment_heading_rad = np.arctan2(seg[:, 1], seg[:, 0])
        # (S,) the same values per component, contiguous (project's arithmetic on x and y apart)
        self._sx, self._sy = (np.ascontiguousarray(a) for a in self.segment_start_m.T)
        self._dx, self._dy = (np.ascontiguousarray(a) for a in self.segment_direction.T)
        self.vertex_s_m = np.concatenate([[0.0], np.cumsum(self.segment_length_m)])
        # (6, S) _project's kernel's table: start x, y [m], unit direction x, y, length [m], arc
        # length at the start [m]
        self.kernel_segment_table = np.ascontiguousarray(np.vstack(
            [self._sx, self._sy, self._dx, self._dy, self.segment_length_m, self.vertex_s_m[:-1]]))
        self.length_m = float(self.vertex_s_m[-1])
        self._seg_start_list = self.segment_start_m.tolist()
        self._seg_dir_list = self.segment_direction.tolist()
        self._seg_len_list = self.segment_length_m.tolist()
        self._cum_s_list = self.vertex_s_m[:-1].tolist()
        # (S, 5) per segment: start x, y [m], unit direction x, y, heading [rad] (point_at)
        self._seg_table = np.column_stack([self.segment_start_m, self.segment_direction,
                                           self.segment_heading_rad])
        # (S, 6) per segment: start x, y [m], unit direction x, y, cos and sin of the heading
        # (pose_at); np.cos / np.sin give each value the same bits wherever it sits in an array
        self.segment_pose_table = np.column_stack([
            self.segment_start_m, self.segment_direction, np.cos(self.segment_heading_rad),
            np.sin(self.segment_heading_rad)])
        self.vertex_s_list = self.vertex_s_m.tolist()  # (S + 1,) point_at_float's lookup
        self._seg_point_list = np.column_stack([self.segment_start_m,
                                                self.segment_direction]).tolist()

    @property
    def n_segments(self) -> int:
        """Number of straight segments of the polyline."""
        return len(self.segment_length_m)

    def project(self, xy) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Project points onto the route.

        Args:
            xy: (..., 2) positions [m].

        Returns:
            s: (...) arc length of the closest point [m] (clamped to [0, length]),
            lateral: (...) signed lateral offset [m], positive to the left of travel,
            heading: (...) route heading at the closest point [rad].
        """
        xy = np.asarray(xy, dtype=np.float64)
        s, lateral, k = self._project(xy[..., 0], xy[..., 1])
        if xy.ndim == 1:  # one point: numpy scalars, as plain indexing gives them
            return s[()], lateral[()], self.segment_heading_rad[int(k)]
        return s, lateral, self.segment_heading_rad[k]

    def project_xy(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """`project`'s arc length and lateral offset of points given as x and y apart.

        Args:
            x: (...) the points' x [m].
            y: (...) their y [m] (x's shape).

        Returns:
            s: (...) arc length of the closest point [m] (clamped to [0, length]),
            lateral: (...) signed lateral offset [m], positive to the left of travel.
        """
        s, lateral, _ = self._project(np.asarray(x, dtype=np.float64),
                                      np.asarray(y, dtype=np.float64))
        return s, lateral

    def _project(self, x: np.ndarray, y: np.ndarray):
        """The projection on x (...) and y (...) [m] kept apart (no (..., S, 2) array).

        Each segment's foot point is clamped to the segment, the closest foot point's segment k
        is chosen (first of equals); the products are summed as rel_x * dir_x + rel_y * dir_y.
        On a route of several segments by a compiled kernel (sim/route_kernels.py, numba
        loaded at the first call), the numpy arithmetic's bits per point.

        Returns:
            s: (...) arc length [m], lateral: (...) signed offset [m], k: (...) segment index.
        """
        sx, sy, dx, dy, length = self._sx, self._sy, self._dx, self._dy, self.segment_length_m
        if len(length) > 1:  # the closest of several segments: compiled (sim/route_kernels.py)
            if x.shape != y.shape:
                x, y = np.broadcast_arrays(x, y)
            shape = x.shape
            out = np.empty((2, x.size))
            k = np.empty(x.size, dtype=np.intp)
            route_kernels().project_points(x.ravel(), y.ravel(), self.kernel_segment_table,
                                           out, k)
            return out[0].reshape(shape), out[1].reshape(shape), k.reshape(shape)
        rel_x = x[..., None] - sx  # (..., 1)
        rel_y = y[..., None] - sy
        t = rel_x * dx + rel_y * dy
        t = np.minimum(np.maximum(t, 0.0), length)  # np.clip's ufuncs
        s = self.vertex_s_m[0] + t[..., 0]
        lateral = dx[0] * rel_y[..., 0] - dy[0] * rel_x[..., 0]
        return np.asarray(s), np.asarray(lateral), np.zeros(s.shape, dtype=np.intp)

    def segment_crossings(self, segment) -> np.ndarray:
        """Arc lengths [m] at which the route crosses a line segment, ascending.

        Args:
            segment: (2, 2) the segment's end points [m] (a stop line, a zone's edge).

        Returns:
            (C,) arc lengths of the crossing points [m]; empty if the route does not cross it.
        """
        seg = np.asarray(segment, dtype=np.float64)
        if seg.shape != (2, 2) or not np.all(np.isfinite(seg)):
            raise ValueError(f"{self.name}: segment must be finite (2, 2) points, got {seg.shape}")
        q, e = seg[0], seg[1] - seg[0]
        d = self._seg_vec  # (S, 2)
        denom = d[:, 0] * e[1] - d[:, 1] * e[0]  # cross(d, e)
        rel = q - self.segment_start_m  # (S, 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (rel[:, 0] * e[1] - rel[:, 1] * e[0]) / denom  # along the route's segment
            u = (rel[:, 0] * d[:, 1] - rel[:, 1] * d[:, 0]) / denom  # along the given segment
        hit = (np.abs(denom) > 1e-12) & (t >= 0.0) & (t <= 1.0) & (u >= 0.0) & (u <= 1.0)
        s = self.vertex_s_m[:-1][hit] + t[hit] * self.segment_length_m[hit]
        return np.unique(s)

    def project_point(self, x: float, y: float) -> tuple[float, float]:
        """Arc length [m] and signed lateral offset [m] of one point: `project`'s, bit for bit.

        The scalar version of `project` (a planner's per-step query): plain Python up to
        PROJECT_POINT_LOOP_MAX segments, where a loop costs less than a call into numpy,
        project itself beyond; the same arithmetic either way (the distance to the foot point
        x - (start + t dir), the first closest segment).
        """
        if len(self.segment_length_m) > PROJECT_POINT_LOOP_MAX:
            s, lateral, _ = self.project(np.array([x, y]))
            return float(s), float(lateral)
        best = (math.inf, 0.0, 0.0)
        for (sx, sy), (dx, dy), length, s0 in zip(self._seg_start_list, self._seg_dir_list,
                                                  self._seg_len_list, self._cum_s_list):
            rx, ry = x - sx, y - sy
            t = min(max(rx * dx + ry * dy, 0.0), length)
            cx, cy = x - (sx + t * dx), y - (sy + t * dy)
            d2 = cx * cx + cy * cy
            if d2 < best[0]:
                best = (d2, s0 + t, dx * ry - dy * rx)
        return best[1], best[2]

    def point_at(self, s) -> tuple[np.ndarray, np.ndarray]:
        """Position and heading at arc length s.

        Args:
            s: (...) arc length [m]; values beyond the ends extrapolate along the end segments.

        Returns:
            xy: (..., 2) [m], heading: (...) [rad].
        """
        s = np.asarray(s, dtype=np.float64)
        if len(self.segment_length_m) == 1:  # k = 0 everywhere: the same arithmetic, no lookup
            local = s - self.vertex_s_m[0]
            xy = self.segment_start_m[0] + local[..., None] * self.segment_direction[0]
            heading = self.segment_heading_rad[0]
            return xy, (np.full(s.shape, heading) if s.ndim else heading)
        k = np.searchsorted(self.vertex_s_m, s, side="right") - 1
        k = np.minimum(np.maximum(k, 0), len(self.segment_length_m) - 1)
        local = s - self.vertex_s_m[k]
        row = self._seg_table[k]  # (..., 5)
        xy = row[..., 0:2] + local[..., None] * row[..., 2:4]
        return xy, (row[..., 4] if s.ndim else self.segment_heading_rad[k])

    def point_at_float(self, s: float) -> tuple[float, float]:
        """`point_at`'s position (x, y) [m] of one arc length s [m], on Python floats.

        The same lookup (searchsorted side="right", clamped to the segments) and the same
        arithmetic (start + (s - segment start s) * direction), bit for bit, without numpy's
        per-call cost (a planner's one look-ahead point per step).
        """
        n_seg = len(self._seg_point_list)
        k = 0 if n_seg == 1 else min(max(bisect.bisect_right(self.vertex_s_list, s) - 1, 0),
                                     n_seg - 1)
        local = s - self.vertex_s_list[k]
        x0, y0, dx, dy = self._seg_point_list[k]
        return x0 + local * dx, y0 + local * dy

    def pose_at(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`point_at`'s position, and the cosine and sine of its heading, in fewer operations.

        The same arithmetic as point_at (and np.cos / np.sin of its heading): the position
        and (cos, sin) are bit for bit those of ``xy, h = point_at(s); cos(h), sin(h)``.

        Args:
            s: (...) arc length [m], an array of at least one dimension.

        Returns:
            xy: (..., 2) [m]; direction: (..., 2) cos and sin of the heading (one row (2,) for
            a single-segment route, where it is the same everywhere).
        """
        table = self.segment_pose_table
        if len(table) == 1:
            local = s - self.vertex_s_m[0]
            return table[0, 0:2] + local[..., None] * table[0, 2:4], table[0, 4:6]
        k = np.searchsorted(self.vertex_s_m, s, side="right") - 1
        k = np.minimum(np.maximum(k, 0), len(table) - 1)
        local = s - self.vertex_s_m[k]
        row = table[k]  # (..., 6)
        return row[..., 0:2] + local[..., None] * row[..., 2:4], row[..., 4:6]


@dataclass(frozen=True)
class Lane:
    """A lane: centerline polyline (P, 2) [m] in travel direction, width [m] and a name.

    Curved lanes (turning lanes of an intersection) are polylines with short segments.
    """

    centerline: np.ndarray
    width_m: float
    name: str = ""

    def polygon(self) -> np.ndarray:
        """(2P, 2) outline of the lane (left edge forward, right edge backward) [m]."""
        route = Route(self.centerline)
        _, heading = route.point_at(route.vertex_s_m)
        normal = np.stack([-np.sin(heading), np.cos(heading)], axis=-1)
        left = self.centerline + 0.5 * self.width_m * normal
        right = self.centerline - 0.5 * self.width_m * normal
        return np.concatenate([left, right[::-1]], axis=0)


@dataclass(frozen=True)
class Crosswalk:
    """A rectangular crosswalk.

    Attributes:
        center: (2,) [m].
        walk_heading_rad: direction in which pedestrians cross [rad].
        length_m: extent along the walking direction (curb to curb, plus margins) [m].
        width_m: extent across the walking direction (along the road) [m].
    """

    center: np.ndarray
    walk_heading_rad: float
    length_m: float
    width_m: float

    def polygon(self) -> np.ndarray:
        """(4, 2) corners [m], counter-clockwise."""
        c, s = np.cos(self.walk_heading_rad), np.sin(self.walk_heading_rad)
        along = np.array([c, s]) * 0.5 * self.length_m
        across = np.array([-s, c]) * 0.5 * self.width_m
        return np.array(
            [
                self.center - along - across,
                self.center + along - across,
                self.center + along + across,
                self.center - along + across,
            ]
        )

    def contains(self, xy, margin_m: float = 0.0) -> np.ndarray:
        """Whether points (..., 2) [m] lie inside the crosswalk grown by margin_m [m]."""
        rel = np.asarray(xy, dtype=np.float64) - self.center
        c, s = np.cos(self.walk_heading_rad), np.sin(self.walk_heading_rad)
        u = rel[..., 0] * c + rel[..., 1] * s
        w = -rel[..., 0] * s + rel[..., 1] * c
        return (np.abs(u) <= 0.5 * self.length_m + margin_m) & (
            np.abs(w) <= 0.5 * self.width_m + margin_m
        )


@dataclass(frozen=True)
class StopLine:
    """A line across a lane at which traffic must stop.

    Attributes:
        segment: (2, 2) end points [m], across the lane.
        kind: "stop_sign" (stop, then go when the way is clear) or "signal" (stop while the
            signal head of this approach shows red or yellow).
        lane: index into RoadMap.lanes of the lane it belongs to (-1: any lane it crosses).
    """

    segment: np.ndarray
    kind: str = "stop_sign"
    lane: int = -1

    def __post_init__(self):
        seg = np.asarray(self.segment, dtype=np.float64)
        if seg.shape != (2, 2) or not np.all(np.isfinite(seg)):
            raise ValueError(f"stop line: segment must be finite (2, 2) points, got {seg.shape}")
        if self.kind not in ("stop_sign", "signal"):
            raise ValueError(f"stop line: kind must be 'stop_sign' or 'signal', got {self.kind!r}")
        object.__setattr__(self, "segment", seg)


@dataclass(frozen=True)
class ConflictZone:
    """An area where lanes cross or merge (part of an intersection).

    Attributes:
        polygon: (V, 2) convex outline [m], counter-clockwise.
        name: used in metrics and error messages.
        priority_lanes: indices into RoadMap.lanes whose traffic has the right of way here;
            traffic on any other lane through the zone yields to it.
    """

    polygon: np.ndarray
    name: str = "conflict"
    priority_lanes: tuple[int, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "polygon",
                           _validate_convex_polygon(self.polygon, f"conflict zone {self.name!r}"))
        object.__setattr__(self, "priority_lanes", tuple(int(i) for i in self.priority_lanes))

    def contains(self, xy, margin_m: float = 0.0) -> np.ndarray:
        """Whether points (..., 2) [m] lie inside the zone grown by margin_m [m] (bool (...))."""
        xy = np.asarray(xy, dtype=np.float64)
        a = self.polygon
        edge = np.roll(a, -1, axis=0) - a  # (V, 2)
        length = np.linalg.norm(edge, axis=1)
        rel = xy[..., None, :] - a  # (..., V, 2)
        cross = (edge[:, 0] * rel[..., 1] - edge[:, 1] * rel[..., 0]) / length
        return np.all(cross >= -margin_m, axis=-1)


def _validate_convex_polygon(poly, name: str) -> np.ndarray:
    """Validate a static polygon: (V>=3, 2), finite, strictly convex; returned counter-clockwise."""
    arr = np.asarray(poly, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 3:
        raise ValueError(f"{name}: expected a polygon of shape (V>=3, 2), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: polygon has non-finite coordinates")
    # (V, 2) edge k from vertex k to k + 1 (the last back to the first), and (V,) the cross
    # product of edge k with edge k + 1 (slices rather than np.roll: this runs for every
    # obstacle of every reset)
    edge = np.empty_like(arr)
    np.subtract(arr[1:], arr[:-1], out=edge[:-1])
    np.subtract(arr[0], arr[-1], out=edge[-1])
    cross = np.empty(len(arr))
    np.subtract(edge[:-1, 0] * edge[1:, 1], edge[:-1, 1] * edge[1:, 0], out=cross[:-1])
    cross[-1] = edge[-1, 0] * edge[0, 1] - edge[-1, 1] * edge[0, 0]
    if (cross < 0).all():
        arr = arr[::-1].copy()
    elif not (cross > 0).all():
        raise ValueError(f"{name}: static polygons must be strictly convex (split concave ones)")
    return arr


@dataclass(frozen=True)
class RoadMap:
    """Everything static in a scenario.

    Attributes:
        lanes: drivable lanes.
        crosswalks: pedestrian crossings.
        static_polygons: convex obstacles (buildings, parked cars), each (V, 2) [m], CCW.
        routes: reference path per agent name.
        speed_limit_mps: legal speed limit [m/s].
        extent: (xmin, xmax, ymin, ymax) of the area worth drawing [m].
        stop_lines: stop lines (stop signs, signalized approaches).
        conflict_zones: areas where lanes cross or merge, with their right of way.
        signal_heads: the traffic signal heads (sim/signals.py), each controlling one stop line
            of kind "signal".
        signal_plan: the fixed-time cycle of their groups (None: no signals). Static, like
            the rest of the map; where the controller is in the cycle is the world's state.
    """

    lanes: tuple[Lane, ...]
    crosswalks: tuple[Crosswalk, ...]
    static_polygons: tuple[np.ndarray, ...]
    routes: dict[str, Route] = field(default_factory=dict)
    speed_limit_mps: float = 13.9
    extent: tuple[float, float, float, float] = (0.0, 100.0, -20.0, 20.0)
    stop_lines: tuple[StopLine, ...] = ()
    conflict_zones: tuple[ConflictZone, ...] = ()
    signal_heads: tuple[SignalHead, ...] = ()
    signal_plan: SignalPlan | None = None

    def __post_init__(self):
        polys = tuple(
            _validate_convex_polygon(p, f"static_polygons[{i}]")
            for i, p in enumerate(self.static_polygons)
        )
        object.__setattr__(self, "static_polygons", polys)
        for i, line in enumerate(self.stop_lines):
            if not -1 <= line.lane < len(self.lanes):
                raise ValueError(f"stop_lines[{i}]: lane {line.lane} is not a lane index")
        for zone in self.conflict_zones:
            bad = [i for i in zone.priority_lanes if not 0 <= i < len(self.lanes)]
            if bad:
                raise ValueError(f"conflict zone {zone.name!r}: priority lanes {bad} are not "
                                 f"lane indices (the map has {len(self.lanes)} lanes)")
        self._check_signals()

    def _check_signals(self) -> None:
        """Every head controls a signal stop line and shows a group of the plan."""
        if self.signal_heads and self.signal_plan is None:
            raise ValueError("road map: signal_heads need a signal_plan")
        for head in self.signal_heads:
            if not 0 <= head.stop_line < len(self.stop_lines):
                raise ValueError(f"signal head {head.name!r}: stop_line {head.stop_line} is not "
                                 f"a stop line index (the map has {len(self.stop_lines)})")
            if self.stop_lines[head.stop_line].kind != "signal":
                raise ValueError(f"signal head {head.name!r}: stop line {head.stop_line} is of "
                                 f"kind {self.stop_lines[head.stop_line].kind!r}, not 'signal'")
            if head.group not in self.signal_plan.groups:
                raise ValueError(f"signal head {head.name!r}: group {head.group!r} is not one of "
                                 f"the plan's {list(self.signal_plan.groups)}")

    def for_agent(self, name: str) -> RoadMap:
        """The map one agent's policy may know: the static map and only its own route.

        Other agents' routes would tell a policy who exists (e.g. a pedestrian route only in a
        scenario with a pedestrian) without observing anything.

        Args:
            name: the agent's name (its route is kept if the map has one).
        """
        own = {name: self.routes[name]} if name in self.routes else {}
        # a shallow copy with only the routes swapped: the rest is this map's, validated once
        # (dataclasses.replace would validate every obstacle again, for every agent)
        agent_map = copy.copy(self)
        object.__setattr__(agent_map, "routes", own)
        return agent_map


class RouteSet:
    """Several routes stacked (segments padded) so that n agents project in one array op.

    Args:
        routes: one Route per agent.
    """

    def __init__(self, routes: list[Route]):
        n = len(routes)
        n_seg = max((len(r.segment_length_m) for r in routes), default=1)
        self.seg_start = np.zeros((n, n_seg, 2))
        self.seg_dir = np.tile([1.0, 0.0], (n, n_seg, 1))
        self.seg_len = np.zeros((n, n_seg))
        self.cum_s = np.zeros((n, n_seg))
        self.valid = np.zeros((n, n_seg), dtype=bool)
        for i, r in enumerate(routes):
            k = len(r.segment_length_m)
            self.seg_start[i, :k] = r.segment_start_m
            self.seg_dir[i, :k] = r.segment_direction
            self.seg_len[i, :k] = r.segment_length_m
            self.cum_s[i, :k] = r.vertex_s_m[:-1]
            self.valid[i, :k] = True
        self.length_m = np.array([r.length_m for r in routes])
        self._all_valid = bool(self.valid.all())

    def project(self, xy) -> tuple[np.ndarray, np.ndarray]:
        """Arc length and signed lateral offset of each agent's position on its own route.

        Args:
            xy: (n, 2) agent positions [m].

        Returns:
            Arc length s (n,) [m] and signed lateral offset (n,) [m] (left positive).
        """
        xy = np.ascontiguousarray(xy, dtype=np.float64)  # a strided view: one kernel signature
        if xy.shape != (len(self.length_m), 2):
            raise ValueError(f"RouteSet.project: xy must have shape ({len(self.length_m)}, 2), "
                             f"one position per route; got {xy.shape}")
        # compiled (sim/route_kernels.py): per agent and segment the clamped foot point, the
        # first closest segment, its arc length and signed offset, with numpy's bits
        return route_kernels().project_on_own_routes(xy, self.seg_start, self.seg_dir,
                                                     self.seg_len, self.cum_s, self.valid,
                                                     self._all_valid)
