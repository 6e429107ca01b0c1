"""sim/pairwise_sum.py sums as np.sum does, bit for bit, and its callers' caches follow its edits."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.sim import pairwise_sum

_PACKAGE = Path(pairwise_sum.__file__).resolve().parents[1]


def _stamp() -> str:
    return hashlib.sha256(Path(pairwise_sum.__file__).read_bytes()).hexdigest()[:16]


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 2000), start=st.integers(0, 9),
       spread=st.sampled_from([1.0, 1e8, 1e300]))
def test_contiguous_sum_is_np_sum(seed, n, start, spread):
    rng = np.random.default_rng(seed)
    values = rng.normal(0.0, spread, start + n)
    got = pairwise_sum.contiguous_sum(values, start, n)
    assert np.float64(got).tobytes() == np.sum(values[start:]).tobytes()


@pytest.mark.parametrize("n", [0, 1, 7, 8, 9, 127, 128, 129, 135, 136, 137, 256, 257, 1023,
                               1024, 1025, 4099, 70001])
def test_block_edges_and_special_values(n):
    """Around numpy's block sizes, with signed zeros, inf and NaN among the values."""
    rng = np.random.default_rng(n)
    values = rng.normal(0.0, 1.0, n) * 10.0 ** rng.integers(-20, 20, n)
    for specials in ([-0.0], [0.0, -0.0], [np.inf], [np.inf, -np.inf], [np.nan]):
        v = values.copy()
        if n:
            v[rng.integers(0, n, 3)] = rng.choice(specials, 3)
        if specials == [-0.0]:
            v[:] = -0.0
        with np.errstate(invalid="ignore"):
            want = np.sum(v)
        got = np.float64(pairwise_sum.contiguous_sum(v, 0, n))
        assert got.tobytes() == want.tobytes() or (np.isnan(got) and np.isnan(want))


def test_every_caller_carries_the_current_stamp():
    """numba caches a kernel under its own file's stamp: a caller must change with the helper.

    Each module that imports marl_social.sim.pairwise_sum names the helper's current digest in
    a comment (`# pairwise_sum.py stamp: ...`), so an edit of the helper must edit them too, and
    numba then compiles them anew instead of loading code with the old helper inlined.
    """
    sources = [Path(folder) / name for folder, _, names in os.walk(_PACKAGE, followlinks=True)
               for name in names if name.endswith(".py")]
    callers = [path for path in sources
               if "marl_social.sim.pairwise_sum import" in path.read_text()]
    assert callers
    stale = [str(path) for path in callers
             if f"pairwise_sum.py stamp: {_stamp()}" not in path.read_text()]
    assert not stale, f"set '# pairwise_sum.py stamp: {_stamp()}' in {stale}"
