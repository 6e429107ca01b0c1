"""numpy's pairwise summation, compiled once for every kernel file that sums as np.sum does.

np.sum of n float64 values along a contiguous axis is 0.0 plus numpy's `pairwise_sum` of
them (`contiguous_sum`): fewer than 8 values added one by one to -0.0; up to PAIRWISE_BLOCK
values eight running sums, combined ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7)), then
the rest one by one; more: the sum of the two halves' sums, the first half n // 2 rounded
down to a multiple of 8 (tests/sim/test_pairwise_sum.py checks it against np.sum).

numba caches a kernel that calls these under its own file's stamp, not this one's: an edit
here must change the stamp line of every caller (tests/sim/test_pairwise_sum.py fails until
it does), so that their caches are rebuilt with the new code.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import types

PAIRWISE_BLOCK = 128  # numpy's PW_BLOCKSIZE: longer runs split in two halves
_SUM = (types.Array(types.float64, 1, "C", readonly=True), types.int64, types.int64)
# at most 3 pending nodes per halving: enough for any run of fewer than 2**40 values
_STACK_DEPTH = 128


@numba.njit(_SUM, cache=True, inline="always")
def _pairwise_block(values, start, n):
    """pairwise_sum of values[start:start + n] for n <= PAIRWISE_BLOCK (no further split)."""
    if n < 8:
        total = -0.0
        for i in range(start, start + n):
            total += values[i]
        return total
    r0, r1, r2, r3 = values[start], values[start + 1], values[start + 2], values[start + 3]
    r4, r5, r6, r7 = values[start + 4], values[start + 5], values[start + 6], values[start + 7]
    i = 8
    while i < n - (n % 8):
        b = start + i
        r0 += values[b]
        r1 += values[b + 1]
        r2 += values[b + 2]
        r3 += values[b + 3]
        r4 += values[b + 4]
        r5 += values[b + 5]
        r6 += values[b + 6]
        r7 += values[b + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        total += values[start + i]
        i += 1
    return total


@numba.njit(_SUM, cache=True)
def pairwise_sum(values, start, n):
    """The pairwise_sum of numpy of values[start:start + n] (its add reduction's inner loop).

    numpy's recursion walked with an explicit stack (numba's on-disk cache does not take
    recursive functions): a post-order walk of the split tree.
    """
    if n <= PAIRWISE_BLOCK:
        return _pairwise_block(values, start, n)
    node_start = np.empty(_STACK_DEPTH, dtype=np.int64)
    node_n = np.empty(_STACK_DEPTH, dtype=np.int64)
    node_split = np.zeros(_STACK_DEPTH, dtype=np.bool_)  # its halves pushed already
    sums = np.empty(_STACK_DEPTH)
    depth, n_sums = 1, 0
    node_start[0], node_n[0] = start, n
    while depth:
        depth -= 1
        first, count = node_start[depth], node_n[depth]
        if count <= PAIRWISE_BLOCK:
            sums[n_sums] = _pairwise_block(values, first, count)
            n_sums += 1
        elif node_split[depth]:
            n_sums -= 1
            sums[n_sums - 1] = sums[n_sums - 1] + sums[n_sums]
        else:
            half = count // 2
            half -= half % 8
            node_split[depth] = True  # this node again, to add its halves' sums
            node_start[depth + 1], node_n[depth + 1] = first + half, count - half
            node_split[depth + 1] = False
            node_start[depth + 2], node_n[depth + 2] = first, half
            node_split[depth + 2] = False
            depth += 3
    return sums[0]


@numba.njit(_SUM, cache=True, inline="always")
def contiguous_sum(values, start, n):
    """np.sum of values[start:start + n], a run along a contiguous axis: 0.0 + pairwise_sum."""
    if n <= PAIRWISE_BLOCK:  # one call less on the common path
        return 0.0 + _pairwise_block(values, start, n)
    return 0.0 + pairwise_sum(values, start, n)
