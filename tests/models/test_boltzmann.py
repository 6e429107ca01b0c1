"""The Boltzmann choice (paper eq. 8): a planner's single row has the rows' bits."""

from __future__ import annotations

import numpy as np

from marl_social.models.boltzmann import boltzmann


def test_one_row_is_a_row_of_the_batch_bit_for_bit():
    rng = np.random.default_rng(3)
    for n_actions in (1, 2, 6, 9, 17):
        q = rng.normal(0, 50, (40, n_actions)) * (rng.random((40, n_actions)) < 0.9)
        q[rng.random(q.shape) < 0.05] = np.inf  # a first action all of whose plans collide
        for beta in (0.0, 0.1, 5.0, 123.0):
            batch = boltzmann(q, beta)
            for row, want in zip(q, batch):
                got = boltzmann(row, beta)
                assert got.shape == want.shape
                assert np.array_equal(got.view(np.int64), want.view(np.int64)), (n_actions, beta)


def test_probabilities_follow_eq_8():
    q = np.array([3.0, 1.0, 2.0])
    p = boltzmann(q, 2.0)
    np.testing.assert_allclose(p, np.exp(-2.0 * q) / np.exp(-2.0 * q).sum())
    assert np.array_equal(boltzmann(q, np.inf), [0.0, 1.0, 0.0])


def _numpy_row(q: np.ndarray, beta: float) -> np.ndarray:
    """The one-row formula in numpy alone (the reference of the compiled exponents)."""
    p = np.exp(-beta * (q - np.minimum.reduce(q)))
    return p / np.add.reduce(p)


def test_one_row_equals_the_numpy_formula_bit_for_bit():
    """cost_kernels.boltzmann_exponents' row: signed-zero ties, huge, non-finite, strided Q."""
    rng = np.random.default_rng(7)
    specials = [0.0, -0.0, np.inf, -np.inf, np.nan, 1e308, -1e308, 5e-324]
    with np.errstate(all="ignore"):
        for _ in range(400):
            n = int(rng.integers(1, 12))
            q = rng.normal(0, 30, n) * (rng.random(n) < 0.8)
            pick = rng.random(n) < rng.choice([0.0, 0.1, 0.4])
            q[pick] = rng.choice(specials, int(pick.sum()))
            for beta in (0.0, 0.1, 5.0, 1e300, -2.0):
                want = _numpy_row(q, beta)
                for row in (q, np.repeat(q, 2)[::2]):  # C-contiguous and strided
                    got = boltzmann(row, beta)
                    assert np.array_equal(got.view(np.int64), want.view(np.int64)), (q, beta)
