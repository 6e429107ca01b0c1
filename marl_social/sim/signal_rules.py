"""What a signal means along a route: which heads a driver obeys, and when it must stop.

* `route_signal_lines`: the signal stop lines a route crosses (a line with a lane index only
  where the route runs the way that lane does), with the head controlling each, in the order the
  route reaches them;
* `must_stop`: red means stop at the line; yellow means stop if the driver can at a comfortable
  deceleration (v^2 / (2 d) <= comfortable_decel_mps2, d the distance of its front to the line),
  else go on (it is in the dilemma zone's "go" part); green means go.

The human drivers (agents/human.py) and the robot (agents/robot/signal_stop.py) read a head's
state from their own observation only (sim/observation.py's signal slots).
"""

from __future__ import annotations

import numpy as np

from marl_social.sim.road_map import RoadMap, Route
from marl_social.sim.signals import GREEN, RED, YELLOW

COMFORTABLE_DECEL_MPS2 = 3.0  # the deceleration a driver accepts to stop on yellow [m/s^2]


# route_signal_lines per (route, map) pair, static map data: {(id(route), id(road_map)):
# (route, road_map, s, head)}, emptied when it reaches this many entries
_MAX_SIGNAL_LINES = 256
_SIGNAL_LINES: dict[tuple[int, int], tuple] = {}


def route_signal_lines(route: Route, road_map: RoadMap) -> tuple[np.ndarray, np.ndarray]:
    """The signal stop lines a route must obey, in the order it reaches them.

    Computed once per (route, map) pair (both static); each call returns its own copies.

    Args:
        route: the driver's route.
        road_map: the static map (its stop lines, lanes and signal heads).

    Returns:
        s (S,) arc lengths [m] at which the route crosses the lines, ascending, and head (S,)
        int, the index into road_map.signal_heads of the head controlling each.
    """
    key = (id(route), id(road_map))
    hit = _SIGNAL_LINES.get(key)
    if hit is None or hit[0] is not route or hit[1] is not road_map:
        hit = (route, road_map, *_route_signal_lines(route, road_map))
        if len(_SIGNAL_LINES) >= _MAX_SIGNAL_LINES:
            _SIGNAL_LINES.clear()
        _SIGNAL_LINES[key] = hit
    return hit[2].copy(), hit[3].copy()


def _route_signal_lines(route: Route, road_map: RoadMap) -> tuple[np.ndarray, np.ndarray]:
    """`route_signal_lines` computed."""
    s_out, head_out = [], []
    for h, head in enumerate(road_map.signal_heads):
        line = road_map.stop_lines[head.stop_line]
        crossings = route.segment_crossings(line.segment)
        if line.lane >= 0 and len(crossings):
            lane = Route(road_map.lanes[line.lane].centerline, f"lane {line.lane}")
            xy, heading = route.point_at(crossings)
            _, _, lane_heading = lane.project(xy)
            crossings = crossings[np.cos(heading - lane_heading) > 0.0]
        s_out.extend(crossings.tolist())
        head_out.extend([h] * len(crossings))
    s = np.asarray(s_out, dtype=np.float64)
    order = np.argsort(s, kind="stable")
    return s[order], np.asarray(head_out, dtype=np.int64)[order]


def must_stop(state: int, speed_mps: float, distance_m: float,
              comfortable_decel_mps2: float = COMFORTABLE_DECEL_MPS2) -> bool:
    """Whether a driver must stop at a signal line (module docstring).

    Args:
        state: the head's state as the driver knows it (RED, YELLOW or GREEN).
        speed_mps: the driver's speed [m/s].
        distance_m: from its front bumper to the line [m] (<= 0: at or past it).
        comfortable_decel_mps2: the deceleration it accepts to stop on yellow [m/s^2].
    """
    if state == GREEN:
        return False
    if state == RED:
        return True
    if state != YELLOW:
        raise ValueError(f"must_stop: unknown signal state {state!r} (RED, YELLOW or GREEN)")
    if distance_m <= 0.0:
        return False
    return speed_mps * speed_mps <= 2.0 * comfortable_decel_mps2 * distance_m
