"""perception/fov_kernels.py gives, bit for bit, what the numpy formulation it replaced gave.

The numpy formulation (FieldOfView.compute before the kernels) is kept here as the reference:
sample points placed by sim.footprint.place_local, offsets, squared distances and bearings
within range and cone, the observers with a static box in range, the depth rays' ends, and the
second round's corner points of the targets whose centre was hidden.
"""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.perception.fov import fov_kernels, sample_point_layout
from marl_social.sim.footprint import place_local


def _reference(xy, heading, local, range_m, half_angle, pair_ok, box_min, box_max, d_obs,
               d_angle, d_range):
    points = place_local(xy, heading, local)  # (n, K, 2)
    rel = points[None, :, :, :] - xy[:, None, None, :]
    dist2 = rel[..., 0] ** 2 + rel[..., 1] ** 2
    bearing = np.arctan2(rel[..., 1], rel[..., 0]) - heading[:, None, None]
    bearing = np.abs((bearing + np.pi) % (2 * np.pi) - np.pi)
    range2 = range_m ** 2
    sensed = ((dist2 <= range2[:, None, None]) & (bearing <= half_angle[:, None, None])
              & pair_ok[..., None])
    if len(box_min):
        gap = np.maximum(np.maximum(box_min[None] - xy[:, None], xy[:, None] - box_max[None]),
                         0.0)
        static_near = (gap[..., 0] ** 2 + gap[..., 1] ** 2 <= range2[:, None]).any(axis=1)
    else:
        static_near = np.zeros(len(xy), dtype=bool)
    d_dir = heading[d_obs] + d_angle
    d_end = np.empty((len(d_obs), 2))
    d_end[:, 0] = np.cos(d_dir)
    d_end[:, 1] = np.sin(d_dir)
    d_end *= d_range[:, None]
    d_end += xy[d_obs]
    return points, rel, sensed, np.nonzero(sensed[:, :, 0]), static_near, d_end


def _kernels(xy, heading, local, range_m, half_angle, pair_ok, box_min, box_max, d_obs,
             d_angle, d_range):
    kernels = fov_kernels()
    points, rel = kernels.sample_points(xy, np.cos(heading), np.sin(heading), local)
    d_dir = heading[d_obs] + d_angle
    sensed, pairs, static_near, d_end = kernels.sensed_rays(
        rel, np.arctan2(rel[..., 1], rel[..., 0]), (xy, heading, range_m ** 2, half_angle, pair_ok),
        (box_min, box_max), (np.cos(d_dir), np.sin(d_dir), d_obs, d_range))
    return points, rel, sensed, tuple(pairs), static_near, d_end


def _scene(rng, n, n_boxes, spread_m):
    state = np.zeros((n, 5))  # the world's state table: xy and heading are its columns
    state[:, :2] = rng.uniform(-spread_m, spread_m, (n, 2))
    state[:, 2] = rng.uniform(-4 * np.pi, 4 * np.pi, n)
    xy, heading = state[:, :2], state[:, 2]
    is_ped = rng.random(n) < 0.4
    length = np.where(is_ped, 0.6, rng.uniform(3.5, 5.5, n))
    width = np.where(is_ped, 0.6, rng.uniform(1.6, 2.2, n))
    local = sample_point_layout(length, width, is_ped)
    active = rng.random(n) < 0.85
    pair_ok = active[:, None] & active[None, :]
    np.fill_diagonal(pair_ok, False)
    range_m = rng.uniform(5.0, 60.0, n)
    sensors = np.zeros((n, 2))  # a table of sensor parameters: the half-angles are a column
    sensors[:, 1] = np.where(rng.random(n) < 0.2, np.pi, rng.uniform(0.2, 2.0, n))
    half_angle = sensors[:, 1]
    corner = rng.uniform(-spread_m, spread_m, (n_boxes, 2))
    box_min, box_max = corner, corner + rng.uniform(1.0, 20.0, (n_boxes, 2))
    n_rays = 7
    observers = np.flatnonzero(active)
    d_obs = np.repeat(observers, n_rays)
    d_angle = rng.uniform(-np.pi, np.pi, len(d_obs))
    return (xy, heading, local, range_m, half_angle, pair_ok, box_min, box_max, d_obs, d_angle,
            range_m[d_obs])


@pytest.mark.parametrize("seed", range(40))
def test_the_kernels_give_numpys_bits(seed):
    rng = np.random.default_rng(seed)
    args = _scene(rng, n=int(rng.integers(1, 12)), n_boxes=int(rng.integers(0, 6)),
                  spread_m=float(rng.choice([5.0, 30.0, 200.0])))
    expected, got = _reference(*args), _kernels(*args)
    for e, g in zip(expected, got):
        e, g = (np.stack(e), np.stack(g)) if isinstance(e, tuple) else (e, g)
        assert e.shape == g.shape and e.dtype == g.dtype
        assert e.tobytes() == g.tobytes()


def test_points_on_the_range_and_cone_edges_are_decided_as_numpy_decides():
    # an observer at the origin facing +x; targets exactly at its range and cone edges
    xy = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [-10.0, 0.0], [7.0710678, 7.0710678]])
    heading = np.zeros(5)
    local = np.zeros((5, 5, 2))
    pair_ok = ~np.eye(5, dtype=bool)
    args = (xy, heading, local, np.full(5, 10.0), np.full(5, np.pi / 2), pair_ok,
            np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, dtype=np.int64), np.zeros(0),
            np.zeros(0))
    expected, got = _reference(*args), _kernels(*args)
    assert np.array_equal(expected[2], got[2])
    assert got[2][0, 1:, 0].tolist() == expected[2][0, 1:, 0].tolist()


@pytest.mark.parametrize("seed", range(20))
def test_second_round_points_are_numpys_nonzero(seed):
    rng = np.random.default_rng(100 + seed)
    n, n_k = int(rng.integers(1, 10)), 5
    sensed = rng.random((n, n, n_k)) < 0.5
    visible = rng.random((n, n)) < 0.5
    reference = sensed.copy()
    reference[:, :, 1:] &= ~visible[..., None]
    o2, t2, k2 = np.nonzero(reference[:, :, 1:])
    got = fov_kernels().hidden_centre_points(sensed, visible)
    assert got.dtype == np.int64
    assert got.tolist() == [o2.tolist(), t2.tolist(), (k2 + 1).tolist()]


def _reference_maybe_blocked(start, end, ray_obs, tgt, centres, radii, static_near):
    """FieldOfView._maybe_blocked (and _segments_hit_circles) before the kernel."""
    maybe = np.ones(len(ray_obs), dtype=bool)
    check = np.flatnonzero(~static_near[ray_obs])
    if len(check):
        s, e = start[check], end[check]
        dx, dy = e[:, 0] - s[:, 0], e[:, 1] - s[:, 1]
        inv_dd = 1.0 / np.maximum(dx * dx + dy * dy, 1e-12)
        wx = np.subtract.outer(-s[:, 0], -centres[:, 0])
        wy = np.subtract.outer(-s[:, 1], -centres[:, 1])
        t = (wx * dx[:, None] + wy * dy[:, None]) * inv_dd[:, None]
        np.clip(t, 0.0, 1.0, out=t)
        wx -= t * dx[:, None]
        wy -= t * dy[:, None]
        blockers = wx * wx + wy * wy <= radii * radii
        rows = np.arange(len(check))
        blockers[rows, ray_obs[check]] = False
        is_target = check < len(tgt)
        blockers[rows[is_target], tgt[check[is_target]]] = False
        maybe[check] = blockers.any(axis=1)
    return maybe


@pytest.mark.parametrize("seed", range(40))
def test_the_broad_phase_kernel_decides_as_numpy(seed):
    rng = np.random.default_rng(300 + seed)
    n, n_rays = int(rng.integers(1, 40)), int(rng.integers(0, 200))
    state = np.zeros((n, 4))  # the world's state table: the centres are a column slice
    state[:, :2] = rng.uniform(-40.0, 40.0, (n, 2))
    centres = state[:, :2]
    active = rng.random(n) < 0.8
    radii = np.where(active, rng.uniform(0.3, 3.0, n), -1.0)
    ray_obs = rng.integers(0, n, n_rays)
    n_target = int(rng.integers(0, n_rays + 1))
    tgt = rng.integers(0, n, n_target)
    start = centres[ray_obs]
    end = start + rng.normal(0.0, 20.0, (n_rays, 2))
    end[: n_rays // 10] = start[: n_rays // 10]  # zero-length rays (the 1e-12 floor)
    static_near = rng.random(n) < 0.3
    expected = _reference_maybe_blocked(start, end, ray_obs, tgt, centres, radii, static_near)
    got = fov_kernels().maybe_blocked(start, end, ray_obs, tgt, centres, radii, static_near)
    assert got.tolist() == expected.tolist()
