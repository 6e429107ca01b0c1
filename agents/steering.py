"""Path tracking shared by the built-in vehicle planners (path-velocity decomposition: the
planners choose the longitudinal behaviour, this supplies the steering)."""

from __future__ import annotations

import math

from marl_social.road_map import Route


def pure_pursuit(route: Route, x: float, y: float, psi: float, v: float, s: float,
                 wheelbase_m: float, min_lookahead_m: float = 6.0,
                 lookahead_time_s: float = 1.0) -> float:
    """Pure-pursuit steering angle [rad] towards the route point one look-ahead distance
    (max(min_lookahead, v * lookahead_time) [m]) ahead of arc length s [m]."""
    lookahead = max(min_lookahead_m, lookahead_time_s * v)
    (tx, ty), _ = route.point_at(s + lookahead)
    alpha = math.atan2(ty - y, tx - x) - psi
    alpha = (alpha + math.pi) % (2 * math.pi) - math.pi
    return math.atan2(2.0 * wheelbase_m * math.sin(alpha), lookahead)
