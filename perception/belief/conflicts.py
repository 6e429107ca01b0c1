"""Where the map's lanes meet the robot's route, and the hidden vehicles that may come on them.

From the map the robot may know (`RoadMap.for_agent(robot)`: the lanes, conflict zones and its
own route; never other agents' routes or names), `lane_conflicts` finds every lane that
crosses or merges into the robot's route: the first point of the lane within half the lane's
width of the route, reached from off the route (a lane that runs along the route, or its
backward extension, from its own start is the robot's lane or one leaving it, and is none).
A conflict zone containing that point decides the right of way: the lane has it if the zone
lists it in priority_lanes; where no zone is given, every lane that meets the route has it
(the robot knows no rule that lets it go first). Lanes parallel to the route never meet it.

`vehicle_hypotheses` turns each conflict with the right of way into hidden-vehicle hypotheses
(hypotheses.Hypothesis, kind "vehicle") along the lane's centre line: progress bins every
progress_step_m from upstream_m before the meeting point up to it (the last bin starts there:
after it the vehicle has passed the conflict and leaves), speed bins at fractions of the speed
limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marl_social.perception.belief.hypotheses import Hypothesis
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.road_map import Lane, RoadMap, Route

LANE_SAMPLE_STEP_M = 0.25  # lanes are sampled this densely to find where they meet a route [m]
MERGE_ANGLE_RAD = math.radians(45.0)  # a lane meeting the route at most this steeply merges
SPEED_MIN_MATCH_MPS = 2.0  # a seen vehicle slower than this along its lane matches no bin [m/s]


@dataclass(frozen=True)
class LaneConflict:
    """Where one lane meets the robot's route.

    Attributes:
        lane_index: index into RoadMap.lanes.
        lane_s_m: arc length along the lane's centre line of the meeting point [m].
        route_s_m: arc length along the robot's route of the meeting point [m].
        kind: "crossing" or "merge" (the lane meets the route within MERGE_ANGLE_RAD).
        zone: name of the conflict zone containing the meeting point ("" without one).
        priority: the lane's traffic has the right of way over the robot there.
    """

    lane_index: int
    lane_s_m: float
    route_s_m: float
    kind: str
    zone: str
    priority: bool


def _meeting_index(lane: Lane, route: Route) -> tuple[np.ndarray, int]:
    """Arc lengths (N,) [m] of the lane's samples and the first one meeting the route (-1: none).

    The first sample within half the lane's width of the route, reached from a sample off the
    route and off its backward extension.
    """
    lane_route = Route(lane.centerline)
    s = np.append(np.arange(0.0, lane_route.length_m, LANE_SAMPLE_STEP_M), lane_route.length_m)
    pts, _ = lane_route.point_at(s)
    route_s, lateral, _ = route.project(pts)
    closest, _ = route.point_at(route_s)
    tol = 0.5 * lane.width_m
    near = np.hypot(*(pts - closest).T) <= tol
    if not near.any():
        return s, -1
    first = int(np.argmax(near))
    # on the route's line: near it, or on its extension behind its start (the robot's lane)
    on_line = near | ((route_s <= 0.0) & (np.abs(lateral) <= tol))
    off = np.flatnonzero(~on_line[:first + 1])
    return s, (first if len(off) else -1)


def lane_conflicts(road_map: RoadMap, route: Route) -> list[LaneConflict]:
    """Every lane of the map that crosses or merges into the route, in lane order.

    Args:
        road_map: the static map (lanes, conflict zones).
        route: the robot's route.
    """
    out = []
    for i, lane in enumerate(road_map.lanes):
        s, first = _meeting_index(lane, route)
        if first < 0:
            continue
        lane_route = Route(lane.centerline)
        point, lane_heading = lane_route.point_at(s[first])
        route_s, _, route_heading = route.project(point)
        diff = (float(lane_heading) - float(route_heading) + math.pi) % (2.0 * math.pi) - math.pi
        kind = "merge" if abs(diff) <= MERGE_ANGLE_RAD else "crossing"
        zones = [z for z in road_map.conflict_zones
                 if bool(z.contains(point, margin_m=0.5 * lane.width_m))]
        priority = not zones or any(i in z.priority_lanes for z in zones)
        out.append(LaneConflict(i, float(s[first]), float(route_s), kind,
                                zones[0].name if zones else "", priority))
    return out


def vehicle_hypotheses(road_map: RoadMap, route: Route | None, speed_fractions,
                       progress_step_m: float, upstream_s: float,
                       vehicle: VehicleParams | None = None) -> list[Hypothesis]:
    """Hidden-vehicle hypotheses on every lane with the right of way where it meets the route.

    Per such lane (`lane_conflicts`, priority only): progress bins starting at the meeting
    point c, c - step, c - 2 step, ... down to c - upstream (and not before the lane's start);
    bin 0 is the most upstream one (where hidden vehicles arrive). Speed bins are
    speed_fractions times the map's speed limit; a seen vehicle matches the bin whose speed is
    nearest to its own (from SPEED_MIN_MATCH_MPS up).

    Args:
        road_map: the map the robot may know.
        route: the robot's route (None: no hypotheses).
        speed_fractions: the speed bins as fractions of road_map.speed_limit_mps.
        progress_step_m: length of a progress bin [m].
        upstream_s: the bins reach this many seconds upstream of the meeting point at the
            fastest speed bin [s].
        vehicle: footprint of a hypothesised vehicle (default VehicleParams()).

    Returns:
        The hypotheses, by lane, progress bin, speed bin (without "none").
    """
    if route is None:
        return []
    vehicle = vehicle or VehicleParams()
    speeds = np.sort(np.asarray(speed_fractions, dtype=np.float64)) * road_map.speed_limit_mps
    if len(speeds) == 0 or not np.all(speeds > 0) or not progress_step_m > 0:
        raise ValueError("vehicle_hypotheses: need positive speed fractions and progress step, "
                         f"got {tuple(speed_fractions)} and {progress_step_m}")
    edges = np.concatenate([[SPEED_MIN_MATCH_MPS], 0.5 * (speeds[1:] + speeds[:-1]), [math.inf]])
    upstream_m = float(upstream_s) * float(speeds.max())
    hyps = []
    for conflict in lane_conflicts(road_map, route):
        if not conflict.priority:
            continue
        lane = road_map.lanes[conflict.lane_index]
        lane_route = Route(lane.centerline)
        n_back = math.floor(min(upstream_m, conflict.lane_s_m) / progress_step_m)
        progress = conflict.lane_s_m - progress_step_m * np.arange(n_back, -1, -1)
        path = f"vehicle_{lane.name or conflict.lane_index}"
        seg = np.diff(lane_route.points, axis=0)
        dirs = seg / np.linalg.norm(seg, axis=1)[:, None]
        _, heading = lane_route.point_at(progress)
        for j, p in enumerate(progress):
            direction = np.array([math.cos(heading[j]), math.sin(heading[j])])
            for m, speed in enumerate(speeds):
                hyps.append(Hypothesis(
                    f"{path}_p{j}_v{m}", True, lane_route.points[0].copy(), direction,
                    float(speed), walk_length_m=lane_route.length_m,
                    half_width_m=0.5 * lane.width_m, kind="vehicle", path=path,
                    progress_m=float(p), progress_bin=j, speed_bin=m,
                    bin_length_m=float(progress_step_m), path_xy=lane_route.points.copy(),
                    path_dir=dirs, length_m=vehicle.length_m, width_m=vehicle.width_m,
                    speed_range_mps=(float(edges[m]), float(edges[m + 1])),
                    lane_index=conflict.lane_index, conflict_m=conflict.lane_s_m,
                ))
    return hyps

