"""The candidate plans and their rollouts along a route (speeds and distances, no scene).

A candidate is a first acceleration u (held for the first segment) followed by a continuation c
(held to the end of the horizon); `CandidateSet` holds them, `rollout_speeds` / `_rollout` roll
them out with the v >= 0 limit, `_governed` holds accelerating continuations to a speed ceiling
(a curve speed). models/candidates.py costs the rollouts against a scene.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from marl_social.sim.dynamics import DT_S


@dataclass(frozen=True)
class CandidateSet:
    """The candidate plans.

    Attributes:
        first_actions_mps2: (A,) first accelerations [m/s^2].
        continuations_mps2: (C,) accelerations after the first segment [m/s^2].
        first_segment_s: how long the first action is held [s].
        horizon_s: planning horizon [s].
        plan_dt_s: rollout step [s]; per-step costs are scaled by plan_dt / DT_S so that sums
            are in simulator-step units.
    """

    first_actions_mps2: tuple
    continuations_mps2: tuple
    first_segment_s: float
    horizon_s: float
    plan_dt_s: float = 0.25

    def __post_init__(self):
        if not self.horizon_s > self.first_segment_s >= self.plan_dt_s > 0:
            raise ValueError("CandidateSet: need horizon_s > first_segment_s >= plan_dt_s > 0")
        if not len(self.first_actions_mps2) or not len(self.continuations_mps2):
            raise ValueError("CandidateSet: need at least one first action and one "
                             "continuation")

    @property
    def n_steps(self) -> int:
        return round(self.horizon_s / self.plan_dt_s)

    @property
    def n_first(self) -> int:
        return round(self.first_segment_s / self.plan_dt_s)

    @property
    def plan_times_s(self) -> np.ndarray:
        """(T,) times of the rollout's states after each planner step [s]."""
        return (np.arange(self.n_steps) + 1) * self.plan_dt_s


def rollout_speeds(v0: float, accel: np.ndarray, dt_s: float = DT_S) -> tuple[np.ndarray, ...]:
    """Speeds and distances of acceleration profiles with the v >= 0 limit, without a time loop.

    v_{k+1} = max(0, v_k + a_k dt) is a Lindley recursion: with S_k = v0 + sum_{i<k} a_i dt,
    v_k = S_k - min(0, min_{j<=k} S_j).

    Args:
        v0: initial speed [m/s].
        accel: (..., T) commanded accelerations [m/s^2].
        dt_s: step length [s].

    Returns:
        v (..., T) speed after each step [m/s], ds (..., T) distance travelled up to each step
        [m], a_eff (..., T) effective acceleration (dv / dt) [m/s^2].
    """
    return _rollout(v0, np.cumsum(accel * dt_s, axis=-1), dt_s)


def _rollout(v0: float, increments: np.ndarray, dt_s: float) -> tuple[np.ndarray, ...]:
    """rollout_speeds from increments (..., T) = cumsum(accel * dt_s) [m/s] (same arithmetic)."""
    shape = increments.shape
    s_full = np.empty(shape[:-1] + (shape[-1] + 1,))
    s_full[..., 0] = v0
    np.add(v0, increments, out=s_full[..., 1:])
    v_full = s_full - np.minimum(0.0, np.minimum.accumulate(s_full, axis=-1))
    v = v_full[..., 1:]
    ds = np.cumsum(0.5 * (v + v_full[..., :-1]) * dt_s, axis=-1)
    return v, ds, (v - v_full[..., :-1]) / dt_s


@dataclass(frozen=True)
class _PlanConstants:
    """What a CandidateSet's rollouts share, computed once per set (read-only arrays).

    Attributes:
        continuations: (C,) continuation accelerations [m/s^2].
        increments: (A, C, T) cumsum(accel * plan_dt) of the candidates' commands [m/s].
    """

    continuations: np.ndarray
    increments: np.ndarray


def cached_or_computed(cached, key):
    """cached(key) for a hashable key; the wrapped function's result for an unhashable one.

    Args:
        cached: a functools.lru_cache-wrapped function of one argument.
        key: its argument (e.g. a frozen dataclass with a field given as a list).
    """
    try:
        return cached(key)
    except TypeError:  # a field that cannot be hashed (e.g. accelerations given as a list)
        return cached.__wrapped__(key)


def _plan_constants(cands: CandidateSet) -> _PlanConstants:
    """The set's _PlanConstants (cached for hashable sets, computed for the others)."""
    return cached_or_computed(_cached_plan_constants, cands)


@functools.lru_cache(maxsize=64)
def _cached_plan_constants(cands: CandidateSet) -> _PlanConstants:
    first = np.asarray(cands.first_actions_mps2, dtype=np.float64)
    cont = np.asarray(cands.continuations_mps2, dtype=np.float64)
    step = np.arange(cands.n_steps)
    accel = np.where(step < cands.n_first, first[:, None, None], cont[None, :, None])  # (A,C,T)
    out = _PlanConstants(cont, np.cumsum(accel * cands.plan_dt_s, axis=-1))
    for array in (out.continuations, out.increments):
        array.setflags(write=False)
    return out


def _governed(v: np.ndarray, ds: np.ndarray, v0: float, cont: np.ndarray, n_first: int,
              dt_s: float, v_ceiling_mps: float) -> tuple[np.ndarray, ...]:
    """Accelerating continuations stop accelerating at a speed ceiling (then hold it).

    "Speed up to the curve speed, then keep it": without it, a driver in a bend could only
    choose between holding its speed and accelerating past the curve speed, and would keep
    putting the acceleration off. The continuation is monotone, so clamping it is exact.

    Args:
        v: (A, C, T) speeds of the plans [m/s].
        ds: (A, C, T) their distances [m] (returned as they are for an infinite ceiling).
        v0: initial speed [m/s].
        cont: (C,) continuation accelerations [m/s^2].
        n_first: steps of the first segment.
        dt_s: step [s].
        v_ceiling_mps: the ceiling [m/s] (inf: nothing changes).

    Returns:
        v, ds, a_eff as rollout_speeds returns them.
    """
    v_full = np.empty(v.shape[:-1] + (v.shape[-1] + 1,))
    v_full[..., 0] = v0
    if not np.isfinite(v_ceiling_mps):
        v_full[..., 1:] = v
        return v, ds, (v - v_full[..., :-1]) / dt_s
    v1 = v[..., n_first - 1: n_first]  # (A, C, 1) speed at the end of the first segment
    rising = (cont > 0)[None, :, None] & (np.arange(v.shape[-1]) >= n_first)
    np.copyto(v_full[..., 1:], np.minimum(v, np.maximum(v1, v_ceiling_mps)), where=rising)
    np.copyto(v_full[..., 1:], v, where=~rising)
    v = v_full[..., 1:]
    ds = np.cumsum(0.5 * (v + v_full[..., :-1]) * dt_s, axis=-1)
    return v, ds, (v - v_full[..., :-1]) / dt_s
