"""models/pedestrian.pedestrian_q_values in numpy, as it stood before its compiled loops."""

from __future__ import annotations

import numpy as np

from marl_social.models.circle_gaps import circle_pair_gap, scene_circles
from marl_social.models.pedestrian import PedestrianModel, _model_constants
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.sim.costs import _crosswalk_conflict, crosswalk_occupancy, object_sum
from marl_social.sim.dynamics import DT_S
from marl_social.sim.road_map import Crosswalk, Route


def pedestrian_q_values(model: PedestrianModel, route: Route, s0: float, v_ref: float,
                    prev_speed: float, scene: ScenePrediction,
                    crosswalks: tuple[Crosswalk, ...]) -> np.ndarray:
    """(L, A) the walks' costs per hypothesis, term by term in numpy (any s0, any M)."""
    dt = model.plan_dt_s
    _, speeds, theta, ego_radius, speed_times, _ = _model_constants(model)
    s = np.minimum(s0 + speed_times, route.length_m)  # (A, T)
    xy, _ = route.pose_at(s)
    accel = np.zeros(s.shape)
    accel[:, 0] = (speeds - prev_speed) / dt
    w_speed, w_accel, w_jerk, w_safety, w_conflict = (float(w) for w in theta[1:])
    n_hyp = len(scene.mask)
    total = None

    def add(total, term):
        return term if total is None else total + term

    if w_speed != 0.0:
        term = np.broadcast_to(speeds[:, None], s.shape) - v_ref
        term *= term
        term *= w_speed
        total = add(total, term)
    if w_accel != 0.0 or w_jerk != 0.0:
        squared = accel * accel  # the jerk's (a - 0.0)^2 too: a - 0.0 == a
        if w_accel != 0.0:
            total = add(total, w_accel * squared)
        if w_jerk != 0.0:
            total = add(total, w_jerk * squared)
    other_mask = scene.mask[:, None, None, :]  # (L, 1, 1, M)
    if w_safety != 0.0:
        ox, oy, other_r = scene_circles(scene)
        gap = circle_pair_gap(xy[None, ..., 0], xy[None, ..., 1], float(ego_radius[0]),
                              ox, oy, other_r)  # (L, A, T, M)
        np.maximum(gap, 0.0, out=gap)
        np.negative(gap, out=gap)
        np.exp(gap, out=gap)
        if not scene.mask.all():
            gap = np.where(other_mask, gap, 0.0)
        term = object_sum(gap)
        term *= w_safety
        total = add(total, term)
    if w_conflict != 0.0 and crosswalks:
        pair_mask = other_mask & ~scene.is_pedestrian[:, None, None, :]  # vehicles
        if not pair_mask.any():  # zeros: they only matter where they broadcast the total
            shape = (n_hyp,) + s.shape
            if total is None or total.shape != shape:
                total = add(total, w_conflict * np.zeros(shape))
        else:
            other_xy = scene.xy.swapaxes(1, 2)[:, None]  # (L, 1, T, M, 2)
            other_radius = scene.radius_m[:, None, None, :]
            conflict = 0.0
            for cw in crosswalks:
                conflict = conflict + _crosswalk_conflict(
                    crosswalk_occupancy(xy, model.radius_m, cw),
                    crosswalk_occupancy(other_xy, other_radius, cw), pair_mask)
            total = add(total, w_conflict * conflict)
    if total is None:
        total = np.zeros(s.shape)
    if total.ndim == 2:  # nothing depended on the scene
        total = np.broadcast_to(total, (n_hyp,) + s.shape)
    return total.sum(axis=-1) * (dt / DT_S)
