"""Compiled (numba) pieces of the belief update: numpy's arithmetic, in its order, in few calls.

The robot's belief works on a few dozen numbers per step (L ~ 13 hypotheses, V = 4 traffic
speeds, A ~ 11 actions), so in numpy its time goes to the number of calls, not to the
arithmetic. These kernels do the additions, products, maxima and comparisons between the
transcendental functions, which stay in numpy (np.exp, np.log, np.arctan2, np.hypot and
np.logaddexp use numpy's own vectorized implementations, whose last bit libm's need not
share), and between the matrix products (BLAS). Every kernel reproduces its numpy reference
bit for bit (tests/perception/test_belief_kernels.py):

* a sum along a contiguous axis is numpy's pairwise sum from 0.0 (`_pairwise_sum`: fewer
  than 8 values one by one, else eight running sums; up to 128 values, which is all the
  belief sums along a contiguous axis);
* a sum over a non-contiguous axis, and np.cumsum, add one by one in index order;
* np.max propagates NaN; np.maximum(x, c) is x unless c > x or c is NaN.

One signature each, `cache=True`, no fastmath, error_model "numpy" (a division by zero gives
inf or NaN as in numpy); a compiled function calls only compiled functions of this file
(numba's cache notices changes of this file only), an index 0 as np.int64(0) (numba would
compile the helper once more for a literal 0). Imported at the first update
(`compiled.kernels`).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types

from marl_social.sim.pairwise_sum import contiguous_sum

# pairwise_sum.py stamp: e57bd2f618419a3d (tests/sim/test_pairwise_sum.py)

_F8 = types.float64
_I8 = types.int64
_B1 = types.boolean
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


def _array(ndim: int, dtype=_F8):
    """The numba type of a read-only C-contiguous array (a writable one converts to it)."""
    return types.Array(dtype, ndim, "C", readonly=True)


def _writable(ndim: int, dtype=_F8):
    """The numba type of a writable C-contiguous array (a kernel that writes into it)."""
    return types.Array(dtype, ndim, "C")


@numba.njit(cache=True)
def _nan_max(values, start, n):
    """np.max of values[start:start + n] (n >= 1): NaN if one is NaN."""
    top = values[start]
    for i in range(start, start + n):
        v = values[i]
        if math.isnan(v):
            return v
        top = max(top, v)
    return top


@numba.njit(cache=True)
def _sanitized(values, start, n, out, out_start):
    """bayes.sanitize_log_likelihood of values[start:start + n] into out[out_start:...]."""
    top = _nan_max(values, start, n)
    good = math.isfinite(top)
    for i in range(n):
        out[out_start + i] = values[start + i] - top if good else 0.0


@numba.njit(cache=True)
def _normalize(pdf):
    """bayes.normalize in place: pdf / np.cumsum(pdf)[-1] (a sum one by one from pdf[0])."""
    total = pdf[0]
    for i in range(1, len(pdf)):
        total += pdf[i]
    for i in range(len(pdf)):
        pdf[i] = pdf[i] / total


@numba.njit((_array(2), _F8), **_JIT)
def boltzmann_exponents(q, beta):
    """-beta (q - q.min(axis=-1)) of Q-values q (R, A), or an empty array if one is not finite.

    action_model.action_log_likelihood's exponent (its check of q first).
    """
    n_rows, n_act = q.shape
    for r in range(n_rows):
        for a in range(n_act):
            if not math.isfinite(q[r, a]):
                return np.empty((0, n_act))
    z = np.empty((n_rows, n_act))
    neg_beta = -beta
    for r in range(n_rows):
        low = q[r, 0]
        for a in range(n_act):
            low = min(low, q[r, a])
        for a in range(n_act):
            z[r, a] = neg_beta * (q[r, a] - low)
    return z


@numba.njit((_array(2),), **_JIT)
def row_sums(values):
    """values.sum(axis=-1) of values (R, A), any A (numpy's pairwise order)."""
    n_rows, n_act = values.shape
    flat = values.ravel()
    out = np.empty(n_rows)
    for r in range(n_rows):
        out[r] = contiguous_sum(flat, r * n_act, n_act)
    return out


@numba.njit((_array(2), _array(1), _array(1)), **_JIT)
def shifted_log_model_terms(z, log_norm, log_kernel):
    """The shifted terms of logsumexp(log_p + log_kernel) and its shift per row.

    With log_p = z - log_norm[r] (the Boltzmann log-probabilities of the R rows (R, A)) and
    log_kernel (A,) the observation's log density under each action: x = log_p + log_kernel,
    top = x.max(axis=-1) (0 where not finite); returns x - top (R, A) and top (R,).
    """
    n_rows, n_act = z.shape
    x = np.empty((n_rows, n_act))
    top = np.empty(n_rows)
    for r in range(n_rows):
        for a in range(n_act):
            x[r, a] = (z[r, a] - log_norm[r]) + log_kernel[a]
        t = _nan_max(x[r], np.int64(0), n_act)
        if not math.isfinite(t):
            t = 0.0
        top[r] = t
        for a in range(n_act):
            x[r, a] = x[r, a] - t
    return x, top


@numba.njit((_array(2), _array(1)), **_JIT)
def node_average_terms(log_lik, log_weights):
    """The shifted terms of logsumexp(log_lik + log_weights[:, None], axis=0) and its shift.

    action_model.speed_averaged_log_likelihood's average over the speed nodes, its check
    first: an empty (0, N) result if a log-likelihood is not finite. x = log_lik (S, N) +
    log_weights (S,), top = x.max(axis=0) (0 where not finite); returns x - top (S, N) and
    top (N,).
    """
    n_nodes, n = log_lik.shape
    for s in range(n_nodes):
        for i in range(n):
            if not math.isfinite(log_lik[s, i]):
                return np.empty((0, n)), np.empty(0)
    x = np.empty((n_nodes, n))
    top = np.empty(n)
    for i in range(n):
        t = log_lik[0, i] + log_weights[0]
        for s in range(n_nodes):
            x[s, i] = log_lik[s, i] + log_weights[s]
            if math.isnan(x[s, i]) or x[s, i] > t:
                t = x[s, i]
        if not math.isfinite(t):
            t = 0.0
        top[i] = t
        for s in range(n_nodes):
            x[s, i] = x[s, i] - t
    return x, top


@numba.njit((_array(2),), **_JIT)
def column_sums(values):
    """values.sum(axis=0) of values (S, N): row by row in index order, as numpy adds them."""
    n_rows, n = values.shape
    out = np.empty(n)
    for i in range(n):
        out[i] = values[0, i]
    for r in range(1, n_rows):
        for i in range(n):
            out[i] = out[i] + values[r, i]
    return out


@numba.njit((_array(1), _F8), **_JIT)
def bounded(log_lik, max_ratio):
    """action_model.bounded_log_likelihood of a flat (N,) array (a copy)."""
    n = len(log_lik)
    out = log_lik.copy()
    for i in range(n):
        if not math.isfinite(log_lik[i]):
            return out
    floor = _nan_max(log_lik, np.int64(0), n) - max_ratio
    for i in range(n):
        if not out[i] >= floor:
            out[i] = floor
    return out


@numba.njit((_writable(1), _array(1), _array(3), _I8), **_JIT)
def joint_log_likelihood(predicted, own, social, n_v):
    """The exponents of the joint update and of its debugging summaries, in one buffer.

    joint_bayes_step's summed and sanitized log-likelihood (N = L V,) of the own sensors'
    (L,) and the H humans' (H, L, V) sources (each sanitized, added own first), then the
    humans' raw sum (N,) sanitized (HiddenAgentBelief.last_likelihoods' "social"), then the
    own sensors' sanitized (L,): a (2 N + L,) buffer for one np.exp. Clips `predicted` (N,)
    at 0 in place (np.maximum(predicted, 0.0)).
    """
    n_l = len(own)
    n = n_l * n_v
    n_h = social.shape[0]
    for i in range(n):  # np.maximum(predicted, 0.0): NaN stays
        predicted[i] = max(predicted[i], 0.0)
    out = np.empty(2 * n + n_l)
    _sanitized(own, np.int64(0), n_l, out, 2 * n)
    total = np.empty(n)
    for i in range(n):
        total[i] = out[2 * n + i // n_v]
    flat = social.ravel()
    rows = np.empty(n)
    raw = np.zeros(n)
    for h in range(n_h):
        _sanitized(flat, h * n, n, rows, np.int64(0))
        for i in range(n):
            total[i] += rows[i]
            raw[i] += flat[h * n + i]
    _sanitized(total, np.int64(0), n, out, np.int64(0))
    _sanitized(raw, np.int64(0), n, out, n)
    return out


@numba.njit((_array(1), _array(1), _F8, _I8), **_JIT)
def joint_posterior(predicted, exp_total, floor, n_v):
    """The joint posterior (L, V) and its floored marginals, or an empty joint if not finite.

    joint_bayes_step after np.exp: predicted * exp(total) normalized; if every entry is finite,
    floored and normalized again; then `floored_marginals`: the sums over v (numpy's pairwise
    order along the contiguous axis) and over l (one by one), floored and normalized. An empty
    joint (0, V) means a non-finite posterior (the caller falls back as bayes_step does).
    """
    n = len(predicted)
    n_l = n // n_v
    posterior = np.empty(n)
    for i in range(n):
        posterior[i] = predicted[i] * exp_total[i]
    _normalize(posterior)
    for i in range(n):
        if not math.isfinite(posterior[i]):
            return np.empty((0, n_v)), np.empty(0), np.empty(0)
    for i in range(n):
        if not posterior[i] >= floor:
            posterior[i] = floor
    _normalize(posterior)
    by_l = np.empty(n_l)
    for i in range(n_l):
        by_l[i] = max(contiguous_sum(posterior, i * n_v, n_v), floor)
    by_v = np.zeros(n_v)
    for i in range(n_l):
        for j in range(n_v):
            by_v[j] += posterior[i * n_v + j]
    for j in range(n_v):
        by_v[j] = max(by_v[j], floor)
    _normalize(by_l)
    _normalize(by_v)
    return posterior.reshape(n_l, n_v), by_l, by_v


@numba.njit(cache=True)
def _speed_q_values_into(base, speeds, v_ref, weight, rows, out, node):
    """`speed_q_values` of one speed's evaluation, written into out[node] (L, V, A)."""
    n_kept, n_act, n_cont = base.shape
    n_t = speeds.shape[2]
    n_v = len(v_ref)
    flat = speeds.ravel()
    squares = np.empty(n_t)
    speed = np.empty((n_v, n_act, n_cont))
    for j in range(n_v):
        for a in range(n_act):
            for c in range(n_cont):
                start = (a * n_cont + c) * n_t
                for t in range(n_t):
                    d = flat[start + t] - v_ref[j]
                    squares[t] = d * d
                speed[j, a, c] = weight * contiguous_sum(squares, np.int64(0), n_t)
    kept = np.empty((n_kept, n_v, n_act))
    for k in range(n_kept):
        for j in range(n_v):
            for a in range(n_act):
                low = base[k, a, 0] + speed[j, a, 0]
                for c in range(n_cont):
                    total = base[k, a, c] + speed[j, a, c]
                    if math.isnan(total):
                        low = total
                        break
                    low = min(low, total)
                kept[k, j, a] = low
    for i in range(len(rows)):  # element by element: no broadcast whose shapes numba must check
        k = rows[i]
        for j in range(n_v):
            for a in range(n_act):
                out[node, i, j, a] = kept[k, j, a]


@numba.njit((_array(3), _array(3), _array(1), _F8, _array(1, _I8)), **_JIT)
def speed_q_values(base, speeds, v_ref, weight, rows):
    """Q* (L, V, A) of every traffic speed: the cheapest continuation with the speed feature.

    social.SocialLikelihood._q_values after the candidates' evaluation: the speed feature
    weight * sum_t (v[a, c, t] - v_ref)^2 (numpy's pairwise sum over the T steps, T <= 128)
    added to base[k, a, c], the minimum over the continuations c (NaN if one is NaN), for
    hypothesis l the kept scene rows[l].

    Args:
        base: (K, A, C) the kept scenes' totals without the speed feature.
        speeds: (A, C, T) the plans' speeds [m/s].
        v_ref: (V,) the traffic speeds [m/s].
        weight: the speed feature's weight per planner step.
        rows: (L,) each hypothesis' row of base.
    """
    out = np.empty((1, len(rows), len(v_ref), base.shape[1]))
    _speed_q_values_into(base, speeds, v_ref, weight, rows, out, np.int64(0))
    return out[0]


_NODES = types.UniTuple(_array(3), 3)


@numba.njit((_NODES, _NODES, _array(1), _F8, _array(1, _I8)), **_JIT)
def node_speed_q_values(bases, speeds, v_ref, weight, rows):
    """`speed_q_values` of three evaluations (the speed nodes of a human's speed): (3, L, V, A).

    Args:
        bases: three (K, A, C) totals without the speed feature, one per node.
        speeds: the three evaluations' (A, C, T) plan speeds [m/s].
        v_ref: (V,) the traffic speeds [m/s].
        weight: the speed feature's weight per planner step.
        rows: (L,) each hypothesis' row of the bases.
    """
    out = np.empty((3, len(rows), len(v_ref), bases[0].shape[1]))
    _speed_q_values_into(bases[0], speeds[0], v_ref, weight, rows, out, np.int64(0))
    _speed_q_values_into(bases[1], speeds[1], v_ref, weight, rows, out, np.int64(1))
    _speed_q_values_into(bases[2], speeds[2], v_ref, weight, rows, out, np.int64(2))
    return out
