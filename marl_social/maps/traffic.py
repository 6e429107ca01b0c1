"""Traffic for a map scene: extra human drivers on the map's lanes near the scene's element.

`traffic_paths(loaded, request)` picks lanes of the map (nearest to the element first, none of
the situation's own lanes), starts a driver at each lane's middle and routes it along the
routing graph (the lane's straightest continuation, scenes.lane_path), with every start at
least TRAFFIC_GAP_M from every other agent's start, so that nobody starts in a collision; a
route ends OCCLUDER_CUT_M before the first occluder of the map it would run into.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from marl_social.maps.elements import LaneKey
from marl_social.maps.scenes import LanePath, _length, lane_path
from marl_social.maps.signal_scenes import OCCLUDER_CUT_M, _cut, _occluder_crossings
from marl_social.sim.road_map import Route

TRAFFIC_GAP_M = 12.0  # a traffic car starts at least this far from every other agent's start [m]
TRAFFIC_BEHIND_M = 10.0  # route kept behind a traffic car's start [m]
TRAFFIC_AHEAD_M = 80.0  # route wanted ahead of it [m]
MIN_AHEAD_M = 20.0  # a route shorter than this ahead of its start is not used [m]
EDGE_EXTENSION_M = 40.0  # as ScenarioNeeds.edge_extension_m [m]


class TrafficRequest(NamedTuple):
    """Where a scene wants its traffic.

    Attributes:
        n: how many drivers.
        centre: (2,) the element's place [m]; lanes nearest to it first.
        box: (xmin, xmax, ymin, ymax) [m]: a lane's middle must lie in it.
        taken: (K, 2) the other agents' starts [m].
        avoid: the situation's own lanes (LaneKeys): no traffic starts on them.
    """

    n: int
    centre: np.ndarray
    box: tuple[float, float, float, float]
    taken: np.ndarray
    avoid: frozenset


def _middle(points: np.ndarray) -> np.ndarray:
    return Route(points).point_at(0.5 * _length(points))[0]


def traffic_paths(loaded, request: TrafficRequest) -> tuple[LanePath, ...]:
    """Up to request.n routes (crossing_m: each driver's start) (module docstring)."""
    road_map, elements = loaded
    x0, x1, y0, y1 = request.box
    candidates: list[tuple[float, LaneKey]] = []
    for key, lane in elements.lanes.items():
        if key in request.avoid:
            continue
        middle = _middle(road_map.lanes[lane.index].centerline)
        if x0 <= middle[0] <= x1 and y0 <= middle[1] <= y1:
            candidates.append((float(np.linalg.norm(middle - request.centre)), key))
    taken = [np.asarray(xy, dtype=np.float64) for xy in request.taken]
    out = []
    for _, key in sorted(candidates):
        if len(out) == request.n:
            break
        line = road_map.lanes[elements.lanes[key].index].centerline
        path = lane_path(loaded, key, 0.5 * _length(line), (TRAFFIC_BEHIND_M, TRAFFIC_AHEAD_M),
                         EDGE_EXTENSION_M)
        route = Route(path.points)
        start = route.point_at(path.crossing_m)[0]
        if taken and min(float(np.linalg.norm(start - xy)) for xy in taken) < TRAFFIC_GAP_M:
            continue
        ahead = _occluder_crossings(_cut(path.points, route.length_m, path.crossing_m),
                                    road_map.static_polygons)
        end = path.crossing_m + (float(ahead[0]) - OCCLUDER_CUT_M if len(ahead)
                                 else route.length_m)
        if end - path.crossing_m < MIN_AHEAD_M:
            continue
        taken.append(start)
        out.append(path._replace(points=_cut(path.points, min(end, route.length_m))))
    return tuple(out)
