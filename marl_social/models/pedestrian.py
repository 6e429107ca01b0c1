"""The pedestrian's decision model: the cost of walking at each candidate speed.

The cost of each candidate speed along its crossing route (0 = wait) over the horizon comes from
the features every agent shares.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from marl_social.models.candidates import ScenePrediction
from marl_social.models.circle_gaps import circle_pair_gap, scene_circles
from marl_social.sim.costs import CostWeights, step_cost
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
        circles' offsets along the heading (C,) [m] and radii (C,) [m] of its disc.
    """
    try:
        return _cached_model_constants(model)
    except TypeError:  # a field that cannot be hashed (e.g. speeds given as a list)
        return _cached_model_constants.__wrapped__(model)


@functools.lru_cache(maxsize=64)
def _cached_model_constants(model: PedestrianModel) -> tuple:
    diam = 2.0 * model.radius_m
    along, radius = circle_layout(diam, diam, True)
    out = (model.plan_times_s, np.array(model.speeds_mps, dtype=np.float64),
           model.theta.as_array(), along, radius)
    for array in out:  # shared by every decision of the model
        array.setflags(write=False)
    return out


def pedestrian_q_values(model: PedestrianModel, route: Route, s0: float, v_ref: float,
                        prev_speed: float, scene: ScenePrediction,
                        crosswalks: tuple[Crosswalk, ...]) -> np.ndarray:
    """Cost (L, A) of walking at each candidate speed for the horizon, per scene hypothesis."""
    dt = model.plan_dt_s
    t, speeds, theta, ego_along, ego_radius = _model_constants(model)
    s = np.minimum(s0 + speeds[:, None] * t[None, :], route.length_m)  # (A, T)
    xy, heading = route.point_at(s)
    v = np.broadcast_to(speeds[:, None], s.shape)
    accel = np.zeros_like(v)
    accel[:, 0] = (speeds - prev_speed) / dt
    # covering circles (footprint.covering_circles): its own coincide (a disc), one stands for
    # all; every circle pair with the others in one broadcast (models/candidates.py)
    ego_x = (xy[..., 0] + ego_along[0] * np.cos(heading))[None]  # (1, A, T)
    ego_y = (xy[..., 1] + ego_along[0] * np.sin(heading))[None]
    ox, oy, other_r = scene_circles(scene)
    gap = np.maximum(circle_pair_gap(ego_x, ego_y, float(ego_radius[0]), ox, oy, other_r), 0.0)
    to_cand = lambda a: a.swapaxes(1, 2)[:, None]  # (L, 1, T, M, ...)
    cost = step_cost(
        theta, lateral_m=0.0, speed_mps=v, v_ref_mps=v_ref, accel_mps2=accel,
        prev_accel_mps2=0.0,
        ego_xy=xy, ego_radius=model.radius_m, ego_is_ped=True, ego_circles=None,
        ego_circle_r=None, other_xy=to_cand(scene.xy),
        other_radius=scene.radius_m[:, None, None, :],
        other_is_ped=scene.is_pedestrian[:, None, None, :], other_circles=None,
        other_circle_r=None, other_mask=scene.mask[:, None, None, :],
        crosswalks=crosswalks, gap=gap,
    )  # (L, A, T)
    return cost.sum(axis=-1) * (dt / DT_S)
