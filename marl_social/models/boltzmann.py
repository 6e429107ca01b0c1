"""Boltzmann (noisily-rational) choice, paper eq. 8: P(u) = softmax(-beta * Q*(x_hat, u))."""

from __future__ import annotations

import math

import numpy as np


def boltzmann(q_values: np.ndarray, beta: float) -> np.ndarray:
    """Choice probabilities P(u) = softmax(-beta * Q) along the last axis.

    beta = inf puts all mass on the argmin (ties split evenly), beta = 0 is uniform.
    """
    q = np.asarray(q_values, dtype=np.float64)
    if math.isinf(beta):
        best = q == q.min(axis=-1, keepdims=True)
        return best / best.sum(axis=-1, keepdims=True)
    if q.ndim == 1:  # one row (a planner's decision): the same reductions, no kept axis
        # -beta (q - min q) in one compiled call (cost_kernels.boltzmann_exponents; numpy
        # for a Q or an exponent that is not finite), np.minimum.reduce and np.add.reduce:
        # q.min() and p.sum() of a 1-D array, without their Python-level wrappers
        z = _exponents(q, beta) if q.flags.c_contiguous else _NO_EXPONENTS
        p = np.exp(z, out=z) if len(z) else np.exp(-beta * (q - np.minimum.reduce(q)))
        return p / np.add.reduce(p)
    z = -beta * (q - q.min(axis=-1, keepdims=True))
    p = np.exp(z)
    return p / p.sum(axis=-1, keepdims=True)


def _exponents(q: np.ndarray, beta: float) -> np.ndarray:
    """cost_kernels.boltzmann_exponents(q, beta) of a 1-D q; (0,): numpy's case (see there)."""
    if not _KERNEL:
        from marl_social.models import kernel_loading

        _KERNEL.append(kernel_loading.load()[1].boltzmann_exponents)
    return _KERNEL[0](q, float(beta))


_KERNEL: list = []  # [cost_kernels.boltzmann_exponents] once loaded
_NO_EXPONENTS = np.zeros(0)
