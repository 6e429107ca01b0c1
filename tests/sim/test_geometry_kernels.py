"""sim/geometry_kernels.py decides as the numpy formulation it replaced decides."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.sim.kernel_cache import geometry_kernels


def _reference(xy, radius, active, static_min, static_max) -> bool:
    """GeometryMirror._bounds_may_touch before the kernel."""
    pairs = ~np.eye(len(xy), dtype=bool) & active[:, None] & active[None, :]
    reach = radius[:, None] + radius
    dx = xy[:, 0:1] - xy[:, 0]
    dy = xy[:, 1:2] - xy[:, 1]
    if ((dx * dx + dy * dy <= reach * reach) & pairs).any():
        return True
    if not len(static_min):
        return False
    gap = np.maximum(np.maximum(static_min - xy[:, None], xy[:, None] - static_max), 0.0)
    radius2 = np.where(active, radius * radius, -1.0)[:, None]
    return bool((gap[..., 0] ** 2 + gap[..., 1] ** 2 <= radius2).any())


def _kernel(xy, radius, active, static_min, static_max) -> bool:
    pairs = ~np.eye(len(xy), dtype=bool) & active[:, None] & active[None, :]
    reach = radius[:, None] + radius
    return geometry_kernels().bounds_may_touch(
        xy, reach * reach, pairs, static_min, static_max, np.where(active, radius * radius, -1.0))


@pytest.mark.parametrize("seed", range(200))
def test_the_kernel_decides_as_numpy(seed):
    rng = np.random.default_rng(seed)
    n, n_boxes = int(rng.integers(1, 9)), int(rng.integers(0, 4))
    state = np.zeros((n, 4))  # the world's state table: xy is a column slice of it
    state[:, :2] = rng.uniform(-30.0, 30.0, (n, 2))
    xy = state[:, :2]
    radius = rng.uniform(0.3, 3.0, n)
    active = rng.random(n) < 0.8
    corner = rng.uniform(-30.0, 30.0, (n_boxes, 2))
    static_min, static_max = corner, corner + rng.uniform(0.5, 10.0, (n_boxes, 2))
    args = (xy, radius, active, static_min, static_max)
    assert _kernel(*args) is _reference(*args)


def test_touching_circles_and_boxes_at_the_limit():
    xy = np.array([[0.0, 0.0], [3.0, 0.0]])
    radius = np.array([1.5, 1.5])  # exactly touching
    both = np.ones(2, bool)
    none = np.zeros((0, 2))
    assert _kernel(xy, radius, both, none, none) is _reference(xy, radius, both, none, none)
    assert _kernel(xy, radius, both, none, none)
    assert not _kernel(xy, radius, np.array([True, False]), none, none)
    box = np.array([[4.5, -1.0]]), np.array([[6.0, 1.0]])  # 1.5 m right of agent 1
    one = np.array([False, True])
    assert _kernel(xy, radius, one, *box) is _reference(xy, radius, one, *box) is True
