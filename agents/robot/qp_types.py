"""What the contingency MPC's QP (qp.py) takes and gives.

Its cost weights, one solve's data and one solution.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class QpWeights:
    """The cost weights of one branch (SI units, per second of plan).

    Attributes:
        speed: w_v on (v - v_ref)^2 [1 / (m/s)^2 / s].
        accel: w_a on a^2 [1 / (m/s^2)^2 / s].
        jerk: w_j on jerk^2 [1 / (m/s^3)^2 / s].
        comfort: w_c on the braking beyond the comfortable deceleration, squared
            [1 / (m/s^2)^2 / s].
    """

    speed: float
    accel: float
    jerk: float
    comfort: float = 0.0


@dataclass(frozen=True)
class QpInstance:
    """One solve's data: the branches' weights, the robot's state and the row bounds.

    Attributes:
        weights: (L,) branch probabilities, summing to one.
        v0: current speed [m/s].
        prev_accel: the previous acceleration command [m/s^2].
        v_ref_mps: reference speed [m/s].
        v_max: (L, N) speed bounds [m/s].
        s_low: (L, N) lower bounds on progress (-inf: none) [m].
        s_up: (L, N) upper bounds on progress + headway x speed (inf: none) [m].
        accel_min: most negative acceleration [m/s^2].
        accel_max: largest acceleration [m/s^2].
        jerk_max: largest |jerk| [m/s^3].
        comfort_decel: the comfortable deceleration (positive) beyond which braking is
            penalized by the comfort weight (None: not penalized) [m/s^2].
        comfort: (L,) factor of each branch's comfort weight (None: 1, every branch).
        goal_weight: w_g of the pull-up term w_g (s - goal_m)^2 [1 / m^2 / s] (0: none).
        goal_m: the progress the pull-up term draws the plan to [m].
    """

    weights: np.ndarray
    v0: float
    prev_accel: float
    v_ref_mps: float
    v_max: np.ndarray
    s_low: np.ndarray
    s_up: np.ndarray
    accel_min: float
    accel_max: float
    jerk_max: float
    comfort_decel: float | None = None
    comfort: np.ndarray | None = None
    goal_weight: float = 0.0
    goal_m: float = 0.0


@dataclass(frozen=True)
class QpSolution:
    """One solve of the QP.

    Attributes:
        solved: OSQP reached a solution within its tolerances that meets the bounds.
        cost: the objective 0.5 x'Px + q'x (constant terms left out).
        accel_mps2: (L, N) accelerations per branch [m/s^2].
        speed_mps: (L, N) speeds at the end of each step [m/s].
        progress_m: (L, N) progress along the route at the end of each step [m].
    """

    solved: bool
    cost: float
    accel_mps2: np.ndarray
    speed_mps: np.ndarray
    progress_m: np.ndarray
