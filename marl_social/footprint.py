"""Footprint geometry shared by the geometry mirrors, fields of view, costs and rendering.

Vehicles are rectangles centred on their reference point; pedestrians are discs.
"""

from __future__ import annotations

import numpy as np

N_COVER_CIRCLES = 3
_COVER_OFFSETS = (np.arange(N_COVER_CIRCLES) - (N_COVER_CIRCLES - 1) / 2) / N_COVER_CIRCLES
_CORNER_SIGNS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])


def box_corners(xy, heading, length, width) -> np.ndarray:
    """Corners of oriented rectangles.

    Args:
        xy: (..., 2) centres [m]; heading: (...) [rad]; length, width: (...) [m].
    Returns:
        (..., 4, 2) corners [m], counter-clockwise from rear-right.
    """
    xy = np.asarray(xy, dtype=np.float64)
    c, s = np.cos(heading)[..., None], np.sin(heading)[..., None]
    hl = 0.5 * np.asarray(length, dtype=np.float64)[..., None] * _CORNER_SIGNS[:, 0]
    hw = 0.5 * np.asarray(width, dtype=np.float64)[..., None] * _CORNER_SIGNS[:, 1]
    corners = np.empty(np.shape(hl) + (2,))
    corners[..., 0] = xy[..., 0:1] + hl * c - hw * s
    corners[..., 1] = xy[..., 1:2] + hl * s + hw * c
    return corners


def covering_circles(xy, heading, length, width, is_pedestrian) -> tuple[np.ndarray, np.ndarray]:
    """Circles covering each footprint (Ziegler et al. 2014): vehicles get N_COVER_CIRCLES equal
    circles along their length, pedestrians the same disc repeated.

    Args:
        xy: (..., 2) [m]; heading, length, width: (...) [m, rad]; is_pedestrian: (...) bool.
            For pedestrians length = width = diameter.
    Returns:
        centres (..., N_COVER_CIRCLES, 2) [m], radii (..., N_COVER_CIRCLES) [m].
    """
    xy = np.asarray(xy, dtype=np.float64)
    if np.ndim(length) == 0 and np.ndim(width) == 0 and np.ndim(is_pedestrian) == 0:
        # one footprint for the whole batch (a planner's candidate trajectories)
        centres = np.empty(np.shape(heading) + (N_COVER_CIRCLES, 2))
        if is_pedestrian:
            centres[...] = xy[..., None, :]
            radius = 0.5 * float(width)
        else:
            along = float(length) * _COVER_OFFSETS
            centres[..., 0] = xy[..., 0:1] + along * np.cos(heading)[..., None]
            centres[..., 1] = xy[..., 1:2] + along * np.sin(heading)[..., None]
            radius = float(np.hypot(length / (2 * N_COVER_CIRCLES), width / 2))
        return centres, np.full(centres.shape[:-1], radius)
    shape = np.broadcast_shapes(np.shape(heading), np.shape(length), np.shape(is_pedestrian))
    length = np.broadcast_to(np.asarray(length, dtype=np.float64), shape)
    width = np.broadcast_to(np.asarray(width, dtype=np.float64), shape)
    is_pedestrian = np.broadcast_to(is_pedestrian, shape)
    heading = np.broadcast_to(heading, shape)
    along = np.where(is_pedestrian, 0.0, length)[..., None] * _COVER_OFFSETS  # (..., C)
    centres = np.empty(np.shape(along) + (2,))
    centres[..., 0] = xy[..., 0:1] + along * np.cos(heading)[..., None]
    centres[..., 1] = xy[..., 1:2] + along * np.sin(heading)[..., None]
    veh_r = np.sqrt((length / (2 * N_COVER_CIRCLES)) ** 2 + (width / 2) ** 2)
    radius = np.where(is_pedestrian, 0.5 * width, veh_r)
    return centres, np.repeat(radius[..., None], N_COVER_CIRCLES, axis=-1)
