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
        xy: (..., 2) centres [m].
        heading: (...) headings [rad].
        length: (...) lengths [m].
        width: (...) widths [m].

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


def circle_layout(length, width, is_pedestrian) -> tuple[np.ndarray, np.ndarray]:
    """Per-footprint constants of the covering circles.

    Ziegler et al. 2014: vehicles get N_COVER_CIRCLES equal circles along their length,
    pedestrians the same disc repeated.

    Args:
        length: (...) footprint lengths [m] (pedestrians: the diameter).
        width: (...) footprint widths [m] (pedestrians: the diameter).
        is_pedestrian: (...) bool.

    Returns:
        Signed offsets of the circle centres along the heading (..., C) [m] and their radii
        (..., C) [m].
    """
    length = np.asarray(length, dtype=np.float64)
    width = np.asarray(width, dtype=np.float64)
    along = np.where(is_pedestrian, 0.0, length)[..., None] * _COVER_OFFSETS
    veh_r = np.sqrt((length / (2 * N_COVER_CIRCLES)) ** 2 + (width / 2) ** 2)
    radius = np.where(is_pedestrian, 0.5 * width, veh_r)
    return along, np.repeat(radius[..., None], N_COVER_CIRCLES, axis=-1)


def place_along(xy, heading, along) -> np.ndarray:
    """Points at signed distances from xy in the heading direction.

    Args:
        xy: (..., 2) origins [m].
        heading: (...) directions [rad].
        along: (..., C) signed distances [m].

    Returns:
        (..., C, 2) points [m]. Shapes broadcast.
    """
    xy = np.asarray(xy, dtype=np.float64)
    along = np.asarray(along, dtype=np.float64)
    x = xy[..., 0:1] + along * np.cos(heading)[..., None]  # (..., C): the broadcast shape
    out = np.empty(x.shape + (2,))
    out[..., 0] = x
    out[..., 1] = xy[..., 1:2] + along * np.sin(heading)[..., None]
    return out


def place_local(xy, heading, local) -> np.ndarray:
    """Body-frame points placed at poses in the world frame.

    Args:
        xy: (..., 2) pose positions [m].
        heading: (...) pose headings [rad].
        local: (..., K, 2) body-frame points [m] (x forward, y left).

    Returns:
        (..., K, 2) world points [m].
    """
    c = np.cos(heading)[..., None]
    s = np.sin(heading)[..., None]
    x = xy[..., 0:1] + local[..., 0] * c - local[..., 1] * s  # (..., K): the broadcast shape
    out = np.empty(x.shape + (2,))
    out[..., 0] = x
    out[..., 1] = xy[..., 1:2] + local[..., 0] * s + local[..., 1] * c
    return out


def covering_circles(xy, heading, length, width, is_pedestrian) -> tuple[np.ndarray, np.ndarray]:
    """Circles covering each footprint (see circle_layout).

    Args:
        xy: (..., 2) centres [m]. Shapes broadcast.
        heading: (...) headings [rad].
        length: (...) lengths [m]; for pedestrians the diameter.
        width: (...) widths [m]; for pedestrians the diameter.
        is_pedestrian: (...) bool.

    Returns:
        centres (..., N_COVER_CIRCLES, 2) [m], radii (..., N_COVER_CIRCLES) [m].
    """
    along, radius = circle_layout(length, width, is_pedestrian)
    centres = place_along(xy, heading, along)
    return centres, np.broadcast_to(radius, centres.shape[:-1])
