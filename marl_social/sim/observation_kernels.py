"""The observation's encoding, compiled by numba.

sim/observation.py loads this module at the first observation of a process (numba is not
imported with `import marl_social`). `encode_rows` writes, value by value, what the numpy
formulation it replaces wrote (kept in tests/sim/test_observation_kernels.py, which checks
the two agree bit for bit): float64 values rounded to the float32 observation as numpy's
assignment rounds them; the cosines and sines come from numpy. No fast-math, no threads.
Compiled once, cached in __pycache__ (cache=True).
"""

from __future__ import annotations

import numba
from numba import types

_F8 = types.float64
_I8 = types.int64
_B1 = types.boolean


def _array(ndim: int, dtype=_F8, layout: str = "A"):
    """The numba type of a read-only array (a writable one converts to it)."""
    return types.Array(dtype, ndim, layout, readonly=True)


_AGENTS = types.Tuple((_array(2), _array(1), _array(1), _array(1), _array(1), _array(1),
                       _array(1, _B1), _array(1), _array(1)))
_MEASURED = types.Tuple((_array(1, _I8), _array(1, _I8), _array(2), _array(2), _array(1),
                         _array(1)))
_COLUMNS = types.UniTuple(_I8, 4)


@numba.njit([types.void(types.Array(types.float32, 2, "C"), _AGENTS, _MEASURED, _array(2),
                        _COLUMNS)],
            cache=True, nogil=True, error_model="numpy")
def encode_rows(out, agents, measured, depth_m, columns):
    """Fill the zeroed observations `out` (n, size) float32 of n agents (no signal slots).

    Ego block: x, y, cos, sin of the heading, speed, sensor range and half-angle, is
    pedestrian. Object slots from column ego_dim: measurement p goes to its observer's slot
    rank = p - (the first row of its observer; `observer` is sorted, as Measurements' rows are),
    if rank < n_slots: present 1, id target + 1, x, y, vx, vy, cos, sin of the measured
    heading, the target's length, width and is_pedestrian. Depth rays from rays_start.

    Args:
        out: (n, size) float32 zeros.
        agents: the n agents' (xy (n, 2) true positions [m], cos_heading (n,) and sin_heading
            (n,) np.cos and np.sin of the true headings, speed (n,) true speeds [m/s],
            sensor_range (n,) [m], half_angle (n,) sensor half-angles [rad], is_pedestrian (n,)
            bool, length (n,) and width (n,) footprints [m]).
        measured: the P measurements' (observer (P,) observing agent, ascending, target (P,)
            observed agent, measured_xy (P, 2) [m], measured_velocity (P, 2) [m/s],
            measured_cos (P,) and measured_sin (P,) np.cos and np.sin of the measured headings).
        depth_m: (n, R) depth ray distances [m].
        columns: (n_slots object slots per observation, ego_dim the ego block's length,
            slot_dim a slot's length, rays_start the column of the first depth ray).
    """
    (xy, cos_heading, sin_heading, speed, sensor_range, half_angle, is_pedestrian, length,
     width) = agents
    observer, target, measured_xy, measured_velocity, measured_cos, measured_sin = measured
    n_slots, ego_dim, slot_dim, rays_start = columns
    for i in range(out.shape[0]):
        row = out[i]
        row[0] = xy[i, 0]
        row[1] = xy[i, 1]
        row[2] = cos_heading[i]
        row[3] = sin_heading[i]
        row[4] = speed[i]
        row[5] = sensor_range[i]
        row[6] = half_angle[i]
        row[7] = 1.0 if is_pedestrian[i] else 0.0
        for r in range(depth_m.shape[1]):
            row[rays_start + r] = depth_m[i, r]
    first = 0  # the first row of the current observer's block (np.searchsorted's, sorted rows)
    for p in range(len(observer)):
        o = observer[p]
        if p > 0 and o != observer[p - 1]:
            first = p
        rank = p - first
        if rank >= n_slots:
            continue
        t = target[p]
        c = ego_dim + rank * slot_dim
        row = out[o]
        row[c] = 1.0
        row[c + 1] = t + 1.0
        row[c + 2] = measured_xy[p, 0]
        row[c + 3] = measured_xy[p, 1]
        row[c + 4] = measured_velocity[p, 0]
        row[c + 5] = measured_velocity[p, 1]
        row[c + 6] = measured_cos[p]
        row[c + 7] = measured_sin[p]
        row[c + 8] = length[t]
        row[c + 9] = width[t]
        row[c + 10] = 1.0 if is_pedestrian[t] else 0.0
