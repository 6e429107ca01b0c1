"""sim/route_rules.on_lanes in numpy, lane by lane, as it stood before sim/route_kernels.on_lanes."""

from __future__ import annotations

import numpy as np

from marl_social.sim.route_rules import (
    LANE_HEADING_TOLERANCE_RAD,
    LANE_LATERAL_MARGIN_M,
    _lane_routes,
)


def on_lanes(lanes, xy, heading) -> np.ndarray:
    """(M,) bool: objects at xy (M, 2) [m] heading (M,) or (1,) [rad] travel along a lane."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    heading = np.asarray(heading, dtype=np.float64).reshape(-1)
    out = np.zeros(len(xy), dtype=bool)
    for lane, route in zip(lanes, _lane_routes(tuple(lanes))):
        s, lateral, lane_heading = route.project(xy)
        inside = (s > 0.0) & (s < route.length_m)
        near = np.abs(lateral) <= 0.5 * lane.width_m + LANE_LATERAL_MARGIN_M
        dpsi = np.abs((heading - lane_heading + np.pi) % (2 * np.pi) - np.pi)
        out |= inside & near & (dpsi <= LANE_HEADING_TOLERANCE_RAD)
    return out
