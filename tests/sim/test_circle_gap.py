"""circle_gap: the gap between footprints equals the plain pairwise circle minimum, bit for bit."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.sim.costs import circle_gap
from marl_social.sim.footprint import covering_circles


def pairwise_gap(ego_c, ego_r, other_c, other_r, clip=True):
    """Reference: every ego circle against every circle of every other footprint."""
    dx = ego_c[..., None, :, None, 0] - other_c[..., :, None, :, 0]
    dy = ego_c[..., None, :, None, 1] - other_c[..., :, None, :, 1]
    gap = np.sqrt(dx * dx + dy * dy) - ego_r[..., None, :, None] - other_r[..., :, None, :]
    gap = gap.min(axis=(-1, -2))
    return np.maximum(gap, 0.0) if clip else gap


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), ego_ped=st.booleans(),
       n_others=st.integers(0, 4), clip=st.booleans())
def test_equals_pairwise_minimum_for_covering_circles(seed, ego_ped, n_others, clip):
    rng = np.random.default_rng(seed)
    ego_c, ego_r = covering_circles(rng.normal(size=(5, 7, 2)) * 8.0, rng.uniform(-4, 4, (5, 7)),
                                    0.6 if ego_ped else 4.6, 0.6 if ego_ped else 1.9, ego_ped)
    is_ped = rng.random(n_others) < 0.5
    length = np.where(is_ped, 0.6, rng.uniform(3.5, 5.5, n_others))
    width = np.where(is_ped, 0.6, rng.uniform(1.6, 2.2, n_others))
    other_c, other_r = covering_circles(rng.normal(size=(3, 1, 7, n_others, 2)) * 8.0,
                                        rng.uniform(-4, 4, (3, 1, 7, n_others)),
                                        length, width, is_ped)
    fast = circle_gap(ego_c, ego_r, other_c, other_r, clip=clip)
    reference = pairwise_gap(ego_c, ego_r, other_c, other_r, clip=clip)
    assert fast.shape == reference.shape == (3, 5, 7, n_others)
    assert np.array_equal(fast, reference)


def test_unequal_radii_within_a_footprint_use_every_pair():
    ego_c = np.array([[0.0, 0.0], [0.0, 0.0]])
    ego_r = np.array([0.5, 2.0])  # coincident centres, different radii: the big one binds
    other_c = np.array([[[5.0, 0.0], [5.0, 0.0]]])
    other_r = np.array([[0.5, 0.5]])
    np.testing.assert_allclose(circle_gap(ego_c, ego_r, other_c, other_r), [2.5])
    np.testing.assert_allclose(circle_gap(ego_c, ego_r, other_c, other_r, clip=False), [2.5])


def test_overlap_is_negative_without_clip():
    ego_c, ego_r = covering_circles(np.zeros(2), 0.0, 4.0, 2.0, False)
    other_c, other_r = covering_circles(np.array([[1.0, 0.0]]), np.zeros(1), np.array([4.0]),
                                        np.array([2.0]), np.array([False]))
    assert circle_gap(ego_c, ego_r, other_c, other_r)[0] == 0.0
    assert circle_gap(ego_c, ego_r, other_c, other_r, clip=False)[0] < -1.0
