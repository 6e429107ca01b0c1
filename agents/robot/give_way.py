"""When the contingency MPC finds no feasible plan: a comfortable stop, and giving way to it.

`comfortable_stop_meets`: whether a comfortable stop begun at a given state keeps a plan's
bounds (MpcResult.surprise_infeasible: an infeasible plan a step after such a stop was still
possible). `contingencies_given_way`: a contingency branch's own hidden vehicle (not a
pedestrian, not in every live branch) gives way to where a comfortable stop gets the robot
(mpc.ContingencyMpc's last fallback before braking at the limit).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from marl_social.agents.robot.corridor import PathObject
from marl_social.agents.robot.mpc_types import BrakingStart

STOP_CHECK_DT_S = 0.005  # integration step of comfortable_stop_meets [s]


def path_object_key(obj: PathObject) -> tuple:
    """What makes two branches' PathObjects the same object (its span, kind and rears)."""
    return (obj.k_first, obj.k_last, obj.is_pedestrian, obj.pass_margin, obj.s_rear_m.tobytes())


def comfortable_stop_meets(start: BrakingStart, bound_m: np.ndarray, v_max_mps: np.ndarray,
                           times_s: np.ndarray, headway_s: np.ndarray, comfort_decel_mps2: float,
                           jerk_max_mps3: float) -> bool:
    """Whether a comfortable stop begun at `start` keeps s + h v <= bound and v <= v_max.

    The acceleration ramps down from start.accel_mps2 at jerk_max_mps3 to
    -comfort_decel_mps2 (at once if it brakes harder already) and holds it until rest; the
    plan's steps end start.lead_s + times_s after the braking starts.

    Args:
        start: where the braking starts (arc length, speed, acceleration) and how long before
            the plan's start.
        bound_m: (N,) the plan's bounds on s + h v, arc lengths along the route [m] (inf: none).
        v_max_mps: (N,) the plan's speed bounds [m/s].
        times_s: (N,) the ends of the plan's steps after its start [s].
        headway_s: (N,) the time headway h of each step [s].
        comfort_decel_mps2: the comfortable deceleration [m/s^2].
        jerk_max_mps3: how fast the braking sets in [m/s^3].
    """
    at = start.lead_s + np.asarray(times_s, dtype=np.float64)
    tau = np.arange(0.0, at[-1] + 2.0 * STOP_CHECK_DT_S, STOP_CHECK_DT_S)
    accel = np.maximum(start.accel_mps2 - jerk_max_mps3 * tau[1:], -comfort_decel_mps2)
    # the acceleration never rises: once at rest the robot stays there
    speed = np.maximum(start.v_mps + np.concatenate([[0.0], np.cumsum(accel)
                                                      * STOP_CHECK_DT_S]), 0.0)
    progress = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1])
                                                * STOP_CHECK_DT_S)])
    v_at, s_at = np.interp(at, tau, speed), np.interp(at, tau, progress)
    bound = np.asarray(bound_m, dtype=np.float64) - start.s_m
    return bool(np.all(s_at + headway_s * v_at <= bound + 1e-9)
                and np.all(v_at <= np.asarray(v_max_mps) + 1e-9))


def contingencies_given_way(per_hyp: list, live_idx, comfort: np.ndarray,
                            rear_floor_m: np.ndarray) -> tuple[list, set]:
    """Per hypothesis, its objects with the contingencies' own vehicles given way.

    A contingency branch's (comfort factor > 0) object that is not a pedestrian and not in
    every live branch (a tracked object is) moves its rear to rear_floor_m at every step it is
    behind that: its stay-behind bound then gives way to a comfortable stop.

    Args:
        per_hyp: per hypothesis, its PathObjects.
        live_idx: the live hypotheses' indices.
        comfort: (L,) the hypotheses' comfort weight factors (> 0: a contingency branch).
        rear_floor_m: (N,) where braking comfortably gets the robot, plus the gap and half a
            car, per plan step [m].

    Returns:
        the objects per hypothesis, and the (hypothesis, index) of every moved one.
    """
    keys = [{path_object_key(o) for o in per_hyp[l]} for l in live_idx]
    shared = set.intersection(*keys) if keys else set()
    eased, moved = list(per_hyp), set()
    for l in live_idx:
        if not comfort[l] > 0.0:
            continue
        objects = []
        for j, obj in enumerate(per_hyp[l]):
            if not obj.is_pedestrian and path_object_key(obj) not in shared:
                obj = replace(obj, s_rear_m=np.maximum(obj.s_rear_m, rear_floor_m))
                moved.add((int(l), j))
            objects.append(obj)
        eased[l] = objects
    return eased, moved
