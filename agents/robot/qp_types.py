"""What the contingency MPC's QP (qp.py) takes and gives: its cost weights and one solution."""

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
