"""The pedestrian's decision model: the cost of walking at each candidate speed.

The cost of each candidate speed along its crossing route (0 = wait) over the horizon comes from
the features every agent shares.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from marl_social.models.circle_gaps import (
    crosswalk_rows,
    scene_circle_inputs,
)
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.sim.costs import (
    OCCUPANCY_SOFTNESS_M,
    CostWeights,
)
from marl_social.sim.dynamics import DT_S
from marl_social.sim.footprint import circle_layout
from marl_social.sim.road_map import Crosswalk, Route


@dataclass(frozen=True)
class PedestrianModel:
    """What defines a pedestrian's decision (its own, or the robot's estimate of it).

    Attributes:
        theta: cost weights.
        beta: rationality (inf = argmin).
        v_walk_mps: walking speed it wants once it crosses [m/s].
        speeds_mps: (A,) candidate speeds along its route [m/s] (0 = wait).
        horizon_s: planning horizon [s].
        plan_dt_s: its rollout step [s] (costs scaled by plan_dt / DT_S, as for drivers).
        expected_yield_decel_mps2: a car that can stop before the crosswalk braking at most
            this hard is expected to yield [m/s^2].
        radius_m: its own disc radius [m].
    """

    theta: CostWeights = field(default_factory=lambda: CostWeights(
        tracking=1.0, speed=1.0, accel=0.01, jerk=0.0, safety=5.0, crosswalk=1000.0))
    beta: float = 5.0
    v_walk_mps: float = 1.3
    speeds_mps: tuple = (0.0, 0.5, 0.9, 1.3, 1.7, 2.0)
    horizon_s: float = 4.0
    plan_dt_s: float = 0.25
    expected_yield_decel_mps2: float = 4.0
    radius_m: float = 0.3

    @property
    def plan_times_s(self) -> np.ndarray:
        """(T,) times of the rollout's states after each planner step [s]."""
        return (np.arange(round(self.horizon_s / self.plan_dt_s)) + 1) * self.plan_dt_s


def _model_constants(model: PedestrianModel) -> tuple:
    """What a decision needs of the model alone, computed once per (hashable) model.

    Returns:
        plan times (T,) [s], candidate speeds (A,) [m/s], theta (N_FEATURES,), the covering
        circles' radii (C,) [m] of its disc, speeds x times (A, T) [m] and the weights of
        speed, accel, jerk, safety and conflict (5,) (theta[1:6] as float64).
    """
    hit = _CONSTANTS_BY_MODEL.get(id(model))  # a frozen model keeps its constants
    if hit is not None and hit[0] is model:
        return hit[1]
    try:
        constants = _cached_model_constants(model)
    except TypeError:  # a field that cannot be hashed (e.g. speeds given as a list)
        constants = _cached_model_constants.__wrapped__(model)
    if len(_CONSTANTS_BY_MODEL) >= 64:
        _CONSTANTS_BY_MODEL.clear()
    _CONSTANTS_BY_MODEL[id(model)] = (model, constants)
    return constants


# id(model) -> (model, its _model_constants): hashing a model takes longer than a lookup
_CONSTANTS_BY_MODEL: dict[int, tuple] = {}


@functools.lru_cache(maxsize=64)
def _cached_model_constants(model: PedestrianModel) -> tuple:
    diam = 2.0 * model.radius_m
    _, radius = circle_layout(diam, diam, True)
    t = model.plan_times_s
    speeds = np.array(model.speeds_mps, dtype=np.float64)
    theta = model.theta.as_array()
    out = (t, speeds, theta, radius, speeds[:, None] * t[None, :], theta[1:6].astype(np.float64))
    for array in out:  # shared by every decision of the model
        array.setflags(write=False)
    return out


def pedestrian_q_values(model: PedestrianModel, route: Route, s0: float, v_ref: float,
                        prev_speed: float, scene: ScenePrediction,
                        crosswalks: tuple[Crosswalk, ...]) -> np.ndarray:
    """Cost (L, A) of walking at each candidate speed for the horizon, per scene hypothesis.

    sim/costs.step_cost of every step (the pedestrian's disc along its route against the
    scene's covering circles, models/circle_gaps.py), summed over the horizon, in simulator-step
    units. Computed term by term in step_cost's order without the terms that add exact zeros
    (its lateral offset is 0, and every feature is >= +0: x + 0.0 == x); its own circles
    coincide with its centre (offset 0 along its heading; the sign of a zero offset cannot
    change a squared distance), so its centre stands for them
    (tests/models/test_pedestrian_costs.py checks it against step_cost bit for bit).
    Compiled loops (models/gap_kernels.py, cost_kernels.py; their numpy reference:
    tests/reference/pedestrian_q.py) compute it; np.exp of the safety feature and np.tanh of
    the crosswalk occupancies stay numpy's.
    """
    gap_kernels, kernels = _KERNELS or _kernels()
    _, speeds, _, ego_radius, speed_times, weights = _model_constants(model)
    w_safety, w_conflict = weights[3], weights[4]
    pair = scene.mask & ~scene.is_pedestrian  # (L, M) the vehicles present
    use_crosswalks = w_conflict != 0.0 and crosswalks and np.count_nonzero(pair) > 0
    rows = crosswalk_rows(crosswalks if use_crosswalks else ())
    exp_arg, occupancy, scene_occupancy = gap_kernels.walk_geometry(
        speed_times, float(s0), route.length_m, route.vertex_s_m, route.segment_pose_table,
        float(ego_radius[0]), *scene_circle_inputs(scene),
        np.ascontiguousarray(scene.radius_m, dtype=float), w_safety != 0.0,
        float(model.radius_m), rows, OCCUPANCY_SOFTNESS_M)
    if w_safety != 0.0:
        np.exp(exp_arg, out=exp_arg)
    if len(occupancy):
        np.tanh(occupancy, out=occupancy)
        np.tanh(scene_occupancy, out=scene_occupancy)
    walk = (float(v_ref), float(prev_speed), float(model.plan_dt_s), model.plan_dt_s / DT_S)
    return kernels.walk_costs(speeds, speed_times.shape[1], walk, weights, exp_arg,
                              np.ascontiguousarray(scene.mask), (occupancy, scene_occupancy, pair))


_KERNELS: list = []  # [gap_kernels, cost_kernels] once loaded


def _kernels() -> tuple:
    """(gap_kernels, cost_kernels), imported at the first call (models/kernel_loading.py)."""
    from marl_social.models import kernel_loading

    _KERNELS[:] = kernel_loading.load()
    return tuple(_KERNELS)
