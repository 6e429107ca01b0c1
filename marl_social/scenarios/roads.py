"""Road helpers shared by the scenarios: straight lanes along +x, their routes and extents.

Every scenario road runs in the +x direction; lanes are LANE_WIDTH_M wide and side by side,
symmetric about y = 0.
"""

from __future__ import annotations

import numpy as np

from marl_social.sim.road_map import Lane, Route

LANE_WIDTH_M = 3.5  # width of every lane [m]


def lane_centres_y(n_lanes: int, lane_width_m: float = LANE_WIDTH_M) -> np.ndarray:
    """(n_lanes,) y of the centrelines of n_lanes side-by-side lanes, symmetric about 0 [m].

    Args:
        n_lanes: number of lanes, >= 1.
        lane_width_m: width of each lane [m].
    """
    return (np.arange(n_lanes) - (n_lanes - 1) / 2) * lane_width_m


def straight_lane(x_start_m: float, x_end_m: float, y_m: float,
                  width_m: float = LANE_WIDTH_M) -> Lane:
    """A straight lane along +x from x_start_m to x_end_m with its centreline at y_m.

    Args:
        x_start_m: x of the lane's start [m].
        x_end_m: x of the lane's end [m], > x_start_m.
        y_m: y of the centreline [m].
        width_m: lane width [m].
    """
    return Lane(np.array([[x_start_m, y_m], [x_end_m, y_m]]), width_m)


def straight_route(name: str, x_start_m: float, x_end_m: float, y_m: float) -> Route:
    """An agent's straight reference path along +x at y_m, from x_start_m to x_end_m.

    Args:
        name: the agent's name (the route's name).
        x_start_m: x of the route's start [m].
        x_end_m: x of the route's end [m], > x_start_m.
        y_m: y of the path [m].
    """
    return Route([[x_start_m, y_m], [x_end_m, y_m]], name)


def road_extent(x_start_m: float, x_end_m: float, half_width_m: float,
                margin_m: float) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) worth drawing [m] of a road symmetric about y = 0.

    Args:
        x_start_m: x of the road's start [m].
        x_end_m: x of the road's end [m].
        half_width_m: how far the scenery reaches on either side of y = 0 [m].
        margin_m: extra room beyond it on both sides [m].
    """
    return (x_start_m, x_end_m, -(half_width_m + margin_m), half_width_m + margin_m)
