"""Path tracking shared by the built-in planners.

Path-velocity decomposition: the planners choose the speed along their route, this turns it into
an action.
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.sim.road_map import Route

MIN_LOOKAHEAD_M = 6.0  # pure pursuit's smallest look-ahead distance [m]
LOOKAHEAD_TIME_S = 1.0  # its look-ahead time at the current speed [s]


def pure_pursuit(route: Route, x: float, y: float, psi: float, v: float, s: float,
                 wheelbase_m: float) -> float:
    """Pure-pursuit steering angle [rad] towards a route point one look-ahead distance ahead.

    The look-ahead distance is max(MIN_LOOKAHEAD_M, v * LOOKAHEAD_TIME_S) [m], counted from
    arc length s.

    Args:
        route: the vehicle's route.
        x: position x [m].
        y: position y [m].
        psi: heading [rad].
        v: speed [m/s].
        s: arc length along the route [m].
        wheelbase_m: wheelbase [m].
    """
    lookahead = max(MIN_LOOKAHEAD_M, LOOKAHEAD_TIME_S * v)
    tx, ty = route.point_at_float(s + lookahead)
    alpha = math.atan2(ty - y, tx - x) - psi
    alpha = (alpha + math.pi) % (2 * math.pi) - math.pi
    return math.atan2(2.0 * wheelbase_m * math.sin(alpha), lookahead)


def walk_along(route: Route, x: float, y: float, speed_mps: float,
               lookahead_m: float = 1.0, s_m: float | None = None) -> np.ndarray:
    """A pedestrian's velocity command (2,) float32 [m/s] along its route.

    The command is speed_mps towards the route point lookahead_m ahead of its projection; zero
    when standing or at the route's end. s_m: route.project_point(x, y)'s arc length [m] when
    the caller has it (None: computed here).
    """
    s = route.project_point(x, y)[0] if s_m is None else s_m
    if speed_mps <= 0.0 or s >= route.length_m - 1e-3:
        return np.zeros(2, dtype=np.float32)
    tx, ty = route.point_at_float(min(s + lookahead_m, route.length_m))
    dx, dy = tx - x, ty - y
    norm = math.hypot(dx, dy)
    if norm < 1e-6:
        return np.zeros(2, dtype=np.float32)
    return np.array([dx / norm * speed_mps, dy / norm * speed_mps], dtype=np.float32)
