"""The robot's vectorized helpers against the per-row numpy they replaced, exactly."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.agents.robot.corridor import occupied_spans
from marl_social.agents.robot.phase_branches import unique_rows

SEEDS = st.integers(0, 2**32 - 1)


@settings(max_examples=300, deadline=None)
@given(SEEDS, st.integers(1, 12), st.integers(0, 70))
def test_unique_rows_is_numpys_unique_along_axis_0(seed, n_rows, n_cols):
    rng = np.random.default_rng(seed)
    rows = rng.random((n_rows, n_cols)) < rng.random()
    if n_rows > 2:
        rows[rng.integers(1, n_rows)] = rows[0]  # a repeated row
    unique, inverse = np.unique(rows, axis=0, return_inverse=True)
    got_unique, got_inverse = unique_rows(rows)
    assert got_unique.dtype == unique.dtype and np.array_equal(got_unique, unique)
    assert got_inverse.dtype == inverse.dtype
    assert np.array_equal(got_inverse, inverse.reshape(-1))


@settings(max_examples=300, deadline=None)
@given(SEEDS, st.integers(0, 40), st.integers(1, 30), st.booleans())
def test_occupied_spans_are_each_rows_first_and_last_true(seed, n_rows, n_steps, select):
    rng = np.random.default_rng(seed)
    occupied = rng.random((n_rows, n_steps)) < rng.random() ** 3
    rows = rng.random(n_rows) < 0.5 if select else None
    expected = []
    for i, row in enumerate(occupied):
        if (rows is None or rows[i]) and row.any():
            ks = np.flatnonzero(row)
            expected.append((i, int(ks[0]), int(ks[-1])))
    got = occupied_spans(occupied, rows)
    assert got == expected
    assert all(type(v) is int for span in got for v in span)
