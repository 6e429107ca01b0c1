"""The noisy measurements' arithmetic (perception/sensors.py), compiled by numba.

perception/sensors.py loads this module at the first measurement of a process (numba is not
imported with `import marl_social`). Each kernel gives, value by value, what the numpy
formulation it replaces gave (kept in tests/perception/test_sensor_kernels.py, which checks
the two agree bit for bit); the noise comes from the episode's numpy generator and the
cosines and sines from numpy. No fast-math, no threads. Compiled once, cached in __pycache__.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types

_F8 = types.float64
_I8 = types.int64
_B1 = types.boolean
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


def _array(ndim: int, dtype=_F8, layout: str = "A"):
    """The numba type of a read-only array (a writable one converts to it)."""
    return types.Array(dtype, ndim, layout, readonly=True)


@numba.njit(cache=True)
def _before(a, b):
    """Whether float a sorts before b as numpy sorts (NaN after every number)."""
    return a < b or (math.isnan(b) and not math.isnan(a))


@numba.njit([(_array(2, _B1), _array(2))], **_JIT)
def visible_pairs(visible, xy):
    """The visible (observer, target) pairs and their distances, as measure orders them.

    np.nonzero(visible), distances sqrt(dx dx + dy dy) (dx = x_target - x_observer), then
    np.lexsort((target, distance, observer))'s order: by observer, then distance, then target
    (a stable insertion sort of each observer's row, which np.nonzero lists by target).

    Args:
        visible: (n, n) bool, visible[observer, target].
        xy: (n, 2) true positions [m].

    Returns:
        observer (P,) int, target (P,) int, distance (P,) [m].
    """
    n = visible.shape[0]
    count = 0
    for o in range(n):
        for t in range(n):
            if visible[o, t]:
                count += 1
    observer = np.empty(count, dtype=np.int64)
    target = np.empty(count, dtype=np.int64)
    distance = np.empty(count)
    p = 0
    for o in range(n):
        start = p
        for t in range(n):
            if not visible[o, t]:
                continue
            dx = xy[t, 0] - xy[o, 0]
            dy = xy[t, 1] - xy[o, 1]
            d = np.sqrt(dx * dx + dy * dy)
            q = p  # insert after every earlier one that does not sort after it
            while q > start and _before(d, distance[q - 1]):
                distance[q] = distance[q - 1]
                target[q] = target[q - 1]
                q -= 1
            distance[q] = d
            target[q] = t
            observer[p] = o
            p += 1
    return observer, target, distance


_TRUTH = types.Tuple((_array(2), _array(1), _array(1), _array(1), _array(1)))
_NOISE_STD = types.UniTuple(_array(1), 3)


@numba.njit([(_array(1, _I8), _array(1, _I8), _array(2), _TRUTH, _NOISE_STD)], **_JIT)
def noisy_values(observer, target, noise, truth, noise_std):
    """Each visible pair's measured position, velocity and heading.

    x + noise_0 pos_noise[observer], v cos(heading) + noise_2 vel_noise[observer], heading +
    noise_4 heading_noise[observer], and likewise in y with noise_1, noise_3 and the sine.

    Args:
        observer: (P,) observing agent of each pair.
        target: (P,) observed agent.
        noise: (P, 5) standard normal draws.
        truth: the n agents' (xy (n, 2) true positions [m], cos_heading (n,) and sin_heading
            (n,) np.cos and np.sin of the true headings, speed (n,) true speeds [m/s],
            heading (n,) true headings [rad]).
        noise_std: each observer's (pos_noise_m (n,) position noise std [m], vel_noise_mps
            (n,) velocity noise std [m/s], heading_noise_rad (n,) heading noise std [rad]).

    Returns:
        positions (P, 2) [m], velocities (P, 2) [m/s], headings (P,) [rad].
    """
    xy, cos_heading, sin_heading, speed, heading = truth
    pos_noise_m, vel_noise_mps, heading_noise_rad = noise_std
    rows = len(observer)
    m_xy = np.empty((rows, 2))
    m_vel = np.empty((rows, 2))
    m_heading = np.empty(rows)
    for p in range(rows):
        o, t = observer[p], target[p]
        m_xy[p, 0] = xy[t, 0] + noise[p, 0] * pos_noise_m[o]
        m_xy[p, 1] = xy[t, 1] + noise[p, 1] * pos_noise_m[o]
        m_vel[p, 0] = speed[t] * cos_heading[t] + noise[p, 2] * vel_noise_mps[o]
        m_vel[p, 1] = speed[t] * sin_heading[t] + noise[p, 3] * vel_noise_mps[o]
        m_heading[p] = heading[t] + noise[p, 4] * heading_noise_rad[o]
    return m_xy, m_vel, m_heading
