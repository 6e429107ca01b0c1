"""Vectorized agent dynamics for vehicles and pedestrians.

Vehicles follow a kinematic bicycle; pedestrians are velocity-commanded discs. Physical limits
saturate (documented per function); nothing here raises on out-of-range values — input
validation lives in the env.

State layout for every agent: [x m, y m, heading rad, speed m/s].
"""

from __future__ import annotations

import numpy as np

DT_S = 0.1  # simulation step [s] (paper, section V)


def saturate_vehicle_action(
    action: np.ndarray,
    speed_mps: np.ndarray,
    wheelbase_m: np.ndarray,
    accel_max_mps2: np.ndarray,
    brake_max_mps2: np.ndarray,
    steer_max_rad: np.ndarray,
    lat_accel_max_mps2: np.ndarray,
) -> np.ndarray:
    """Clip [acceleration, steering] to the physical limits.

    Acceleration is clipped to [-brake_max, accel_max]; steering to
    |delta| <= min(steer_max, atan(wheelbase * lat_accel_max / v^2)) so that the lateral
    acceleration v^2 * kappa (kappa = tan(delta) / wheelbase) stays within the G-G limit.

    Args:
        action: (n, 2) [a m/s^2, delta rad].
        speed_mps: (n,) speed of each vehicle [m/s].
        wheelbase_m: (n,) wheelbase of each vehicle [m].
        accel_max_mps2: (n,) largest acceleration of each vehicle [m/s^2].
        brake_max_mps2: (n,) largest braking deceleration of each vehicle (positive) [m/s^2].
        steer_max_rad: (n,) largest steering angle of each vehicle [rad].
        lat_accel_max_mps2: (n,) largest lateral acceleration of each vehicle [m/s^2].

    Returns:
        (n, 2) saturated actions.
    """
    # clip(x, lo, hi) is minimum(maximum(x, lo), hi), written out: np.clip's and np.stack's
    # Python wrappers cost more than the arithmetic on a few agents
    out = np.empty((len(action), 2))
    out[:, 0] = np.minimum(np.maximum(action[:, 0], -brake_max_mps2), accel_max_mps2)
    v2 = np.maximum(speed_mps, 1e-3) ** 2
    steer_lim = np.minimum(steer_max_rad, np.arctan(wheelbase_m * lat_accel_max_mps2 / v2))
    out[:, 1] = np.minimum(np.maximum(action[:, 1], -steer_lim), steer_lim)
    return out


def bicycle_step(
    state: np.ndarray, action: np.ndarray, wheelbase_m: np.ndarray, speed_max_mps: np.ndarray,
    dt_s: float = DT_S,
) -> np.ndarray:
    """Kinematic bicycle model (Rajamani 2011, ch. 2), one step for n vehicles.

    The reference point is at the footprint centre and the rear axle wheelbase/2 behind it.

    beta = atan(tan(delta) / 2);  x' = v cos(psi + beta);  y' = v sin(psi + beta);
    psi' = v cos(beta) tan(delta) / wheelbase;  v' = a.
    Speed saturates to [0, speed_max] (no reversing); the position update uses the mean of the
    speeds at the start and end of the step, so a car braking to a stop stops where it should.

    Args:
        state: (n, 4) [x m, y m, psi rad, v m/s].
        action: (n, 2) saturated [a m/s^2, delta rad].
        wheelbase_m: (n,) wheelbase of each vehicle [m].
        speed_max_mps: (n,) top speed of each vehicle [m/s].
        dt_s: step length [s].

    Returns:
        (n, 4) next state.
    """
    x, y, psi, v = state.T
    accel, steer = action.T
    v_next = np.minimum(np.maximum(v + accel * dt_s, 0.0), speed_max_mps)
    v_mid = 0.5 * (v + v_next)
    tan_d = np.tan(steer)
    beta = np.arctan(0.5 * tan_d)
    psi_next = psi + v_mid * np.cos(beta) * tan_d / wheelbase_m * dt_s
    psi_mid = 0.5 * (psi + psi_next)
    out = np.empty((len(state), 4))
    out[:, 0] = x + v_mid * np.cos(psi_mid + beta) * dt_s
    out[:, 1] = y + v_mid * np.sin(psi_mid + beta) * dt_s
    out[:, 2] = (psi_next + np.pi) % (2.0 * np.pi) - np.pi
    out[:, 3] = v_next
    return out


HUGE_COMMAND_MPS = 1e150  # above this a component's square could overflow [m/s]


def saturate_pedestrian_action(action: np.ndarray, speed_max_mps: np.ndarray) -> np.ndarray:
    """Scale each velocity command so that its norm is <= speed_max.

    A command with a component above HUGE_COMMAND_MPS is first divided by its largest absolute
    component, so its norm cannot overflow: 1e155 in x saturates to speed_max along x, not to 0.

    Args:
        action: (n, 2) finite velocity commands (vx, vy) [m/s].
        speed_max_mps: (n,) top speed of each pedestrian [m/s].

    Returns:
        (n, 2) saturated commands [m/s].
    """
    max_abs = np.abs(action).max(axis=1)
    huge = max_abs > HUGE_COMMAND_MPS
    if huge.any():  # direction first, then the norm of a vector of components <= 1
        action = action.copy()
        action[huge] = action[huge] / max_abs[huge, None]
        action[huge] *= (speed_max_mps[huge] / np.linalg.norm(action[huge], axis=1))[:, None]
    norm = np.sqrt(action[:, 0] * action[:, 0] + action[:, 1] * action[:, 1])
    scale = np.where(norm > speed_max_mps, speed_max_mps / np.maximum(norm, 1e-12), 1.0)
    return action * scale[:, None]


def pedestrian_step(state: np.ndarray, velocity_mps: np.ndarray, dt_s: float = DT_S) -> np.ndarray:
    """Point-mass pedestrian: moves by its (saturated) velocity command (n, 2) [m/s].

    Heading follows the velocity; a standing pedestrian (|v| < 1 cm/s) keeps its heading.
    Returns (n, 4) [x, y, psi, speed].
    """
    out = np.empty((len(state), 4))
    out[:, 3] = np.sqrt(velocity_mps[:, 0] * velocity_mps[:, 0]
                        + velocity_mps[:, 1] * velocity_mps[:, 1])  # |v|, as np.linalg.norm
    out[:, 2] = np.where(out[:, 3] > 1e-2, np.arctan2(velocity_mps[:, 1], velocity_mps[:, 0]),
                         state[:, 2])
    out[:, :2] = state[:, :2] + velocity_mps * dt_s
    return out
