"""Geometry helpers for intersection scenarios: turning paths, boxes, stop lines, parked cars.

Turning paths are polylines: straight pieces joined by circular arcs sampled every
ARC_STEP_M, so that lanes and routes through an intersection are ordinary `Lane` / `Route`
polylines (the curvature is in the vertices). Angles are radians counter-clockwise from +x;
lengths are metres.
"""

from __future__ import annotations

import math

import numpy as np

ARC_STEP_M = 0.5  # largest distance between the sampled points of an arc [m]
JOIN_TOLERANCE_M = 1e-6  # consecutive points closer than this are one point [m]


def arc_points(centre, radius_m: float, start_rad: float, end_rad: float) -> np.ndarray:
    """(P, 2) points of a circular arc from angle start_rad to end_rad, both ends included [m].

    The arc runs counter-clockwise when end_rad > start_rad (a left turn), clockwise otherwise
    (a right turn). Angles are those of the points seen from the centre.

    Args:
        centre: (2,) the circle's centre [m].
        radius_m: its radius [m], > 0.
        start_rad: angle of the first point [rad].
        end_rad: angle of the last point [rad].
    """
    if not radius_m > 0:
        raise ValueError(f"arc radius must be > 0, got {radius_m}")
    n = max(2, math.ceil(abs(end_rad - start_rad) * radius_m / ARC_STEP_M) + 1)
    angle = np.linspace(start_rad, end_rad, n)
    return np.asarray(centre, dtype=np.float64) + radius_m * np.column_stack(
        [np.cos(angle), np.sin(angle)])


def polyline(*pieces) -> np.ndarray:
    """(P, 2) the pieces ((P_i, 2) each) joined in order, a shared joint point kept once [m]."""
    points = np.concatenate([np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in pieces])
    step = np.linalg.norm(np.diff(points, axis=0), axis=1)
    keep = np.concatenate([[True], step > JOIN_TOLERANCE_M])
    return points[keep]


def box(x_min: float, x_max: float, y_min: float, y_max: float) -> np.ndarray:
    """(4, 2) an axis-aligned rectangle, counter-clockwise from (x_min, y_min) [m]."""
    if not (x_max > x_min and y_max > y_min):
        raise ValueError(f"box: need x_max > x_min and y_max > y_min, got "
                         f"x [{x_min}, {x_max}], y [{y_min}, {y_max}]")
    return np.array([[x_min, y_min], [x_max, y_min], [x_max, y_max], [x_min, y_max]])


def parked_row(x_near: float, x_far: float, y_m: float, length_m: float, width_m: float,
               gap_m: float) -> list[np.ndarray]:
    """Parked cars bumper to bumper along x, from x_near towards x_far, gap_m apart.

    Only whole cars between x_near and x_far are placed.

    Args:
        x_near: where the row starts (the first car's near bumper) [m].
        x_far: where it ends [m]; the row runs towards -x if x_far < x_near.
        y_m: the cars' centre line [m].
        length_m: car length [m].
        width_m: car width [m].
        gap_m: free space between two cars [m], >= 0.

    Returns:
        The cars' (4, 2) outlines, counter-clockwise [m].
    """
    direction = 1.0 if x_far >= x_near else -1.0
    pitch = length_m + gap_m
    n = int((abs(x_far - x_near) + gap_m) // pitch)
    cars = []
    for k in range(n):
        a = x_near + direction * k * pitch
        b = a + direction * length_m
        cars.append(box(min(a, b), max(a, b), y_m - 0.5 * width_m, y_m + 0.5 * width_m))
    return cars
