"""sim/costs.object_sum: one order over the objects' axis, whatever the memory layout."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.sim.costs import object_sum
from marl_social.sim.pairwise_sum import contiguous_sum
from tests.helpers import same_bits


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), rows=st.integers(1, 6),
       n_obj=st.one_of(st.integers(0, 20), st.integers(120, 300)))
def test_the_sum_over_the_objects_does_not_depend_on_the_layout(seed, rows, n_obj):
    """C order, objects strided (a transposed copy), broadcast rows: the same bits as the
    compiled pairwise sum of each row (np.sum alone adds a strided axis one by one)."""
    rng = np.random.default_rng(seed)
    values = np.exp(-rng.uniform(0.0, 30.0, (rows, n_obj)))  # >= +0, as the features are
    want = np.array([contiguous_sum(row, 0, n_obj) for row in values])
    strided = np.asfortranarray(values)
    broadcast = np.broadcast_to(values[:1], (rows, n_obj))
    assert same_bits(object_sum(values), want)
    assert same_bits(object_sum(strided), want)
    assert same_bits(object_sum(broadcast), np.repeat(want[:1], rows))
    if n_obj >= 8 and rows > 1:  # the reason for it: np.sum's order follows the layout
        assert strided.strides[-1] != strided.itemsize
