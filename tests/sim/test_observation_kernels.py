"""sim/observation_kernels.py writes, bit for bit, what the numpy encoding it replaced wrote."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.sim.bodies import Bodies
from marl_social.sim.observation import EGO_DIM, SLOT_DIM, Measurements, ObservationLayout


def _reference(layout, xy, heading, speed, sensor_range, sensor_half_angle, is_pedestrian,
               length, width, m, depth_m) -> np.ndarray:
    """ObservationLayout.encode before the kernel (no signal slots)."""
    n = len(xy)
    out = np.zeros((n, layout.size), dtype=np.float32)
    out[:, 0:2] = xy
    out[:, 2] = np.cos(heading)
    out[:, 3] = np.sin(heading)
    out[:, 4] = speed
    out[:, 5] = sensor_range
    out[:, 6] = sensor_half_angle
    out[:, 7] = is_pedestrian
    if len(m.observer):
        first = np.searchsorted(m.observer, m.observer, side="left")
        rank = np.arange(len(m.observer)) - first
        keep = rank < layout.n_slots
        obs_i, rank, tgt = m.observer[keep], rank[keep], m.target[keep]
        heading_k, m_xy, m_vel = m.heading[keep], m.xy[keep], m.velocity[keep]
        slot = np.empty((len(tgt), SLOT_DIM))
        slot[:, 0] = 1.0
        slot[:, 1] = tgt + 1.0
        slot[:, 2:4] = m_xy
        slot[:, 4:6] = m_vel
        slot[:, 6] = np.cos(heading_k)
        slot[:, 7] = np.sin(heading_k)
        slot[:, 8] = length[tgt]
        slot[:, 9] = width[tgt]
        slot[:, 10] = is_pedestrian[tgt]
        slots = out[:, EGO_DIM:EGO_DIM + layout.n_slots * SLOT_DIM].reshape(
            n, layout.n_slots, SLOT_DIM)
        slots[obs_i, rank] = slot
    out[:, EGO_DIM + layout.n_slots * SLOT_DIM:EGO_DIM + layout.n_slots * SLOT_DIM
        + layout.n_rays] = depth_m
    return out


@pytest.mark.parametrize("seed", range(60))
def test_the_kernel_writes_numpys_bits(seed):
    rng = np.random.default_rng(seed)
    n, n_slots, n_rays = int(rng.integers(1, 9)), int(rng.integers(1, 5)), int(rng.integers(1, 8))
    layout = ObservationLayout(n_slots=n_slots, n_rays=n_rays)
    state = np.zeros((n, 5))  # the world's state table: its columns are strided views
    state[:, :2] = rng.normal(0.0, 1e3, (n, 2))
    state[:, 2] = rng.uniform(-10.0, 10.0, n)
    state[:, 3] = rng.uniform(0.0, 30.0, n)
    is_ped = rng.random(n) < 0.4
    visible = (rng.random((n, n)) < 0.6) & ~np.eye(n, dtype=bool)
    observer, target = np.nonzero(visible)
    rows = len(observer)
    m = Measurements(observer, target, rng.normal(0.0, 1e3, (rows, 2)),
                     rng.normal(0.0, 10.0, (rows, 2)), rng.uniform(-7.0, 7.0, rows),
                     rng.uniform(0.0, 50.0, rows))
    args = (state[:, :2], state[:, 2], state[:, 3], rng.uniform(5.0, 80.0, n),
            rng.uniform(0.1, np.pi, n), is_ped, rng.uniform(0.5, 5.0, n),
            rng.uniform(0.5, 2.0, n), m, rng.uniform(0.0, 80.0, (n, n_rays)))
    expected = _reference(layout, *args)
    xy, heading, speed, sensor_range, half_angle, is_ped, length, width, m, depth = args
    bodies = Bodies(xy, heading, speed, length, width, is_ped, np.hypot(length, width) / 2,
                    np.ones(n, bool), sensor_range, half_angle)
    got = layout.encode(bodies, m, depth)
    assert got.dtype == np.float32 and got.shape == expected.shape
    assert got.tobytes() == expected.tobytes()
