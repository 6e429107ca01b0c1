"""sim/costs.pairwise_step_features in numpy, as it stood before sim/feature_kernels.py."""

from __future__ import annotations

import numpy as np

from marl_social.sim.costs import (
    N_FEATURES,
    AgentFootprints,
    AgentMotion,
    StepInputs,
    _crosswalk_conflict,
    _feature_terms,
    _pairwise_conflict,
)


def pairwise_step_features(motion: AgentMotion, bodies: AgentFootprints, other_mask: np.ndarray,
                           crosswalks: tuple, kinds_differ: np.ndarray | None = None
                           ) -> np.ndarray:
    """(n, N_FEATURES) the features of n agents who are each other's others, in numpy."""
    lateral_m, speed_mps, v_ref_mps, accel_mps2, prev_accel_mps2 = motion
    xy, radius, is_ped, circles, circle_r = bodies
    d = circles[:, None, :, None, :] - circles[None, :, None, :, :]  # (n, n, C, C, 2)
    dx, dy = d[..., 0], d[..., 1]
    nearest = (dx * dx + dy * dy).min(axis=(2, 3))
    gap = np.maximum(np.sqrt(nearest) - circle_r[:, None, 0] - circle_r[None, :, 0], 0.0)
    out = np.empty((len(xy), N_FEATURES))
    out[:, :5] = np.stack(np.broadcast_arrays(*_feature_terms(StepInputs(
        lateral_m=lateral_m, speed_mps=speed_mps, v_ref_mps=v_ref_mps, accel_mps2=accel_mps2,
        prev_accel_mps2=prev_accel_mps2, ego_xy=None, ego_radius=None, ego_is_ped=None,
        ego_circles=None, ego_circle_r=None, other_xy=None, other_radius=None,
        other_is_ped=None, other_circles=None, other_circle_r=None, other_mask=other_mask,
        crosswalks=(), gap=gap), (True,) * 5 + (False,))[:5]), axis=-1)
    out[:, 5] = _pairwise_conflict(
        xy, radius, is_ped, other_mask, crosswalks, kinds_differ,
        lambda occ, pair_mask: _crosswalk_conflict(occ, occ[None, :], pair_mask))
    return out
