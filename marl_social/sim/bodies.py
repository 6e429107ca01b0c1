"""The agents' bodies and sensors at one instant, as arrays with one row per agent."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Bodies(NamedTuple):
    """What the field of view and the observation read of n agents at one instant.

    Attributes:
        xy: (n, 2) true positions [m].
        heading: (n,) true headings [rad].
        speed: (n,) true speeds [m/s].
        length_m: (n,) footprint lengths [m].
        width_m: (n,) footprint widths [m].
        is_pedestrian: (n,) bool.
        bounding_radius_m: (n,) bounding-circle radii [m] (the field of view's broad phase).
        active: (n,) bool; inactive agents neither see nor occlude.
        sensor_range_m: (n,) sensor ranges [m].
        sensor_half_angle_rad: (n,) half-angles of the view cones [rad].
    """

    xy: np.ndarray
    heading: np.ndarray
    speed: np.ndarray
    length_m: np.ndarray
    width_m: np.ndarray
    is_pedestrian: np.ndarray
    bounding_radius_m: np.ndarray
    active: np.ndarray
    sensor_range_m: np.ndarray
    sensor_half_angle_rad: np.ndarray
