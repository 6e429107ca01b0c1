"""Compiled (numba) loops that lay out a decision's scene from its tracks.

`constant_velocity_scene` is `ScenePrediction.from_tracks`'s constant-velocity positions and
repeated headings (models/candidates.py) -- TrackSet.predict_xy's xy + velocity x time, one
multiplication and one addition per value as numpy does them (numba's defaults do not contract
them into a fused multiply-add), and copies of the headings -- in one call instead of a
handful of broadcasting numpy calls (tests/models/test_scene_kernels.py: bit for bit).

Imported with the planners' other kernels (models/kernel_loading.py); `cache=True` as there.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import types

_F8 = types.float64


def _any_layout(ndim: int):
    """The numba type of a read-only float64 array of any layout (a view of a track table)."""
    return types.Array(_F8, ndim, "A", readonly=True)


@numba.njit([(_any_layout(2), _any_layout(2), _any_layout(1), _any_layout(1))],
            cache=True, nogil=True, error_model="numpy")
def constant_velocity_scene(xy, velocity, heading, times_s):
    """One hypothesis of M tracks moving at constant velocity, at T times.

    Args:
        xy: (M, 2) the tracks' positions now [m].
        velocity: (M, 2) their velocities [m/s].
        heading: (M,) their footprint headings [rad].
        times_s: (T,) the prediction times [s].

    Returns:
        xy (1, M, T, 2): xy + velocity x time [m] (TrackSet.predict_xy's arithmetic);
        heading (1, M, T): each track's heading repeated over the times [rad].
    """
    n_obj, n_t = xy.shape[0], times_s.shape[0]
    out_xy = np.empty((1, n_obj, n_t, 2))
    out_heading = np.empty((1, n_obj, n_t))
    for m in range(n_obj):
        x, y, vx, vy, psi = xy[m, 0], xy[m, 1], velocity[m, 0], velocity[m, 1], heading[m]
        for t in range(n_t):
            out_xy[0, m, t, 0] = x + vx * times_s[t]
            out_xy[0, m, t, 1] = y + vy * times_s[t]
            out_heading[0, m, t] = psi
    return out_xy, out_heading
