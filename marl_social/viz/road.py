"""The static map drawn on a matplotlib Axes: road, markings, crosswalks, stop lines, houses.

Signal heads are drawn as dark squares (`signal_head_squares`); their changing colour is the
live frames' business (`frames.Renderer.draw` colours them with the world's signal states).

Shared by the live frames (`frames.Renderer`, rasterised once into cached tiles) and the
episode figure (`figures.plot_episode`, panel (a)). All coordinates are metres in the world
frame, angles radians counter-clockwise from +x; line widths are points [pt].
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.collections import LineCollection, PolyCollection

from marl_social.sim.road_map import Crosswalk, Lane, RoadMap, Route
from marl_social.viz.style import (
    CROSSWALK_PERIOD_M,
    CROSSWALK_STRIPE_M,
    HOUSE_COLOR,
    HOUSE_EDGE_COLOR,
    HOUSE_EDGE_PT,
    LANE_DASH_M,
    LANE_DIVIDER_LINE_PT,
    MARKING_COLOR,
    ROAD_COLOR,
    ROAD_EDGE_LINE_PT,
    ROAD_EDGE_WIDTH_PT,
    SIGNAL_HEAD_EDGE_COLOR,
    SIGNAL_HEAD_M,
    SIGNAL_HEAD_OFF_COLOR,
    STOP_LINE_PT,
)

POINT_IN_LANE_TOL_M = 0.05  # a point this close to a lane's outline is on the lane [m]


def _dash_segments(polyline: np.ndarray, on_m: float, off_m: float) -> list[np.ndarray]:
    """Painted pieces (P_k, 2) [m] of a dashed line along a polyline (P, 2) [m].

    Args:
        polyline: (P, 2) points of the line [m].
        on_m: painted length of one dash [m].
        off_m: gap between two dashes [m].
    """
    route = Route(polyline)
    starts = np.arange(0.5 * off_m, route.length_m, on_m + off_m)
    pieces = []
    for s0 in starts:
        s1 = min(s0 + on_m, route.length_m)
        inner = route.vertex_s_m[(route.vertex_s_m > s0) & (route.vertex_s_m < s1)]  # keep corners
        xy, _ = route.point_at(np.concatenate([[s0], inner, [s1]]))
        pieces.append(xy)
    return pieces


def _point_in_lane(point: np.ndarray, lane: Lane, tol_m: float = POINT_IN_LANE_TOL_M) -> bool:
    """Whether a point (2,) [m] lies inside or on the outline of a lane (within tol_m [m])."""
    route = Route(lane.centerline)
    s, lateral, _ = route.project(point)
    half_width_m = 0.5 * lane.width_m
    return bool(-tol_m <= s <= route.length_m + tol_m and abs(lateral) <= half_width_m + tol_m)


def lane_markings(road_map: RoadMap) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Solid road edges and dashed lane dividers as polylines (P, 2) [m].

    A lane edge whose midpoint lies on another lane is a divider (drawn once, dashed); any other
    edge borders the road (solid).

    Args:
        road_map: the map whose lanes are marked.

    Returns:
        (solid, dashed): the road edges, and the painted pieces of the dividers.
    """
    solid, dashed = [], []
    for i, lane in enumerate(road_map.lanes):
        outline = lane.polygon()
        p = len(lane.centerline)
        for edge in (outline[:p], outline[p:][::-1]):
            mid = 0.5 * (edge[0] + edge[1])
            shared = [j for j, other in enumerate(road_map.lanes)
                      if j != i and _point_in_lane(mid, other)]
            if not shared:
                solid.append(edge)
            elif i < min(shared):
                dashed.extend(_dash_segments(edge, *LANE_DASH_M))
    return solid, dashed


def crosswalk_stripes(crosswalk: Crosswalk) -> list[np.ndarray]:
    """Zebra stripes (4, 2) [m] of a crosswalk.

    The bars run parallel to the traffic and are spaced CROSSWALK_PERIOD_M along the walking
    direction, centred on the crosswalk.

    Args:
        crosswalk: the crosswalk (center (2,) [m], walk_heading_rad [rad], length_m and
            width_m [m]).
    """
    c, s = math.cos(crosswalk.walk_heading_rad), math.sin(crosswalk.walk_heading_rad)
    along, across = np.array([c, s]), np.array([-s, c])
    half_len, half_w = 0.5 * crosswalk.length_m, 0.5 * crosswalk.width_m
    n = max(1, int((crosswalk.length_m + CROSSWALK_PERIOD_M - CROSSWALK_STRIPE_M)
                   // CROSSWALK_PERIOD_M))
    used = (n - 1) * CROSSWALK_PERIOD_M + CROSSWALK_STRIPE_M
    u0 = -half_len + 0.5 * (crosswalk.length_m - used)
    stripes = []
    for k in range(n):
        a = u0 + k * CROSSWALK_PERIOD_M
        b = min(a + CROSSWALK_STRIPE_M, half_len)
        stripes.append(np.array([
            crosswalk.center + a * along - half_w * across,
            crosswalk.center + b * along - half_w * across,
            crosswalk.center + b * along + half_w * across,
            crosswalk.center + a * along + half_w * across,
        ]))
    return stripes


def signal_head_squares(road_map: RoadMap) -> list[np.ndarray]:
    """(4, 2) squares [m] of side SIGNAL_HEAD_M centred on each signal head, map order."""
    half = 0.5 * SIGNAL_HEAD_M
    corners = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
    return [head.position + corners for head in road_map.signal_heads]


def draw_road_map(ax, road_map: RoadMap, line_scale: float = 1.0) -> None:
    """Draw the static map (road, markings, crosswalks, stop lines, houses) on an Axes.

    Args:
        ax: the Axes (data units metres).
        road_map: the map.
        line_scale: multiplies the marking line widths [pt].
    """
    lanes = [lane.polygon() for lane in road_map.lanes]
    if lanes:
        ax.add_collection(PolyCollection(lanes, facecolors=ROAD_COLOR, edgecolors=ROAD_COLOR,
                                         linewidths=ROAD_EDGE_WIDTH_PT, zorder=0.5))
    solid, dashed = lane_markings(road_map)
    if solid:
        ax.add_collection(LineCollection(solid, colors=MARKING_COLOR,
                                         linewidths=ROAD_EDGE_LINE_PT * line_scale, zorder=0.7))
    if dashed:
        ax.add_collection(LineCollection(dashed, colors=MARKING_COLOR,
                                         linewidths=LANE_DIVIDER_LINE_PT * line_scale,
                                         zorder=0.7))
    stripes = [st for cw in road_map.crosswalks for st in crosswalk_stripes(cw)]
    if stripes:
        ax.add_collection(PolyCollection(stripes, facecolors=MARKING_COLOR, edgecolors="none",
                                         zorder=0.8))
    if road_map.stop_lines:
        ax.add_collection(LineCollection([line.segment for line in road_map.stop_lines],
                                         colors=MARKING_COLOR,
                                         linewidths=STOP_LINE_PT * line_scale, zorder=0.8))
    if road_map.signal_heads:
        ax.add_collection(PolyCollection(signal_head_squares(road_map),
                                         facecolors=SIGNAL_HEAD_OFF_COLOR,
                                         edgecolors=SIGNAL_HEAD_EDGE_COLOR,
                                         linewidths=HOUSE_EDGE_PT * line_scale, zorder=0.95))
    if road_map.static_polygons:
        ax.add_collection(PolyCollection(list(road_map.static_polygons), facecolors=HOUSE_COLOR,
                                         edgecolors=HOUSE_EDGE_COLOR,
                                         linewidths=HOUSE_EDGE_PT * line_scale, zorder=0.9))
