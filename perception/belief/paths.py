"""A tracked car's path, inferred from its track and the static map's lanes (never its name).

The robot knows the lanes of the map, not where each other car is going: a tracked vehicle
drives along the lane whose centre line is nearest to it (within the lane's half width plus
LANE_MATCH_MARGIN_M) and whose heading matches the track's heading (within
LANE_MATCH_HEADING_RAD). Intersections will add the lane's possible continuations as
hypotheses; on the straight roads of today each lane has one.
"""

from __future__ import annotations

import math

from marl_social.sim.road_map import RoadMap, Route

LANE_MATCH_MARGIN_M = 0.5  # a car this far outside a lane's edges still drives in it [m]
LANE_MATCH_HEADING_RAD = math.radians(45.0)  # largest track-to-lane heading difference [rad]


class LanePaths:
    """The map's lanes as routes, and the lane a tracked car drives in.

    Args:
        road_map: the static map (its lanes).
    """

    def __init__(self, road_map: RoadMap):
        """Turn every lane's centre line into a Route."""
        self.routes = [Route(lane.centerline, f"lane_{i}") for i, lane in enumerate(road_map.lanes)]
        self._half_width_m = [0.5 * lane.width_m for lane in road_map.lanes]

    def route_of(self, xy, heading_rad: float) -> Route | None:
        """The route of the lane a car at xy (2,) [m] heading heading_rad [rad] drives in.

        None if no lane matches (off the road, or driving against every lane).
        """
        x, y = float(xy[0]), float(xy[1])
        best, best_offset = None, math.inf
        for route, half in zip(self.routes, self._half_width_m):
            s, lateral = route.project_point(x, y)
            if abs(lateral) > half + LANE_MATCH_MARGIN_M or abs(lateral) >= best_offset:
                continue
            _, lane_heading = route.point_at(s)
            diff = (heading_rad - float(lane_heading) + math.pi) % (2.0 * math.pi) - math.pi
            if abs(diff) <= LANE_MATCH_HEADING_RAD:
                best, best_offset = route, abs(lateral)
        return best

