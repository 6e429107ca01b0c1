"""Multi-object tracking from an agent's own observations: one Kalman filter per object.

filterpy's predict / update (the same array operations in the same order, without their
per-call argument handling: `kf_predict`, `kf_update`), constant-velocity model, state
[x m, y m, vx m/s, vy m/s].

Association is by the object id in the observation slot (a perception stack's track id). A track
that is not measured coasts on its prediction and is dropped after `timeout_s`.

A track's heading (its footprint's orientation) is the direction of the filtered velocity while
the object moves at `MOVING_MPS` or more, else the last measured box heading: a stopped car's
velocity estimate is noise, and a 4.5 m box turned to its direction would sweep across the
neighbouring lane.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy import dot

from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import SLOT_INDEX, DecodedObservation

MOVING_MPS = 1.0  # below this tracked speed the heading is the measured box heading [m/s]
MIN_NOISE_STD = 1e-3  # measurement noise stds are at least this [m, m/s]
# covariance steps shared by trackers of one model (Tracker._covariance_step), per model; a
# table is emptied when it reaches this many entries
_MAX_COVARIANCE_STEPS = 4096
_COVARIANCE_STEPS: dict[tuple, dict] = {}
# slot columns of the measured state [x m, y m, vx m/s, vy m/s]
# (consecutive in SLOT_FIELDS)
_MEASURED_STATE = slice(SLOT_INDEX["x"], SLOT_INDEX["vy"] + 1)


def kf_predict(x: np.ndarray, P: np.ndarray, F: np.ndarray, Q: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """`filterpy.kalman.predict(x, P, F, Q)`: the same operations, bit for bit.

    Args:
        x: (d,) state.
        P: (d, d) covariance.
        F: (d, d) transition.
        Q: (d, d) process noise.

    Returns:
        the predicted (x, P).
    """
    return dot(F, x) + dot(1, 0), (1 * 1) * dot(dot(F, P), F.T) + Q


def kf_update(x: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray,
              H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`filterpy.kalman.update(x, P, z, R, H)` for a 1-D state and z: the same operations.

    Joseph form, P = (I - KH) P (I - KH)^T + K R K^T, bit for bit as filterpy computes it.

    Args:
        x: (d,) predicted state.
        P: (d, d) predicted covariance.
        z: (m,) float measurement.
        R: (m, m) measurement noise.
        H: (m, d) measurement matrix.

    Returns:
        the updated (x, P).
    """
    y = z - dot(H, x)
    S = dot(dot(H, P), H.T) + R
    K = dot(dot(P, H.T), np.linalg.inv(S))
    x = x + dot(K, y)
    KH = dot(K, H)
    I_KH = np.eye(KH.shape[0]) - KH
    return x, dot(dot(I_KH, P), I_KH.T) + dot(dot(K, R), K.T)


@dataclass(frozen=True)
class TrackSet:
    """Current tracks (k of them), arrays in a fixed order (ascending object id).

    Attributes:
        ids: (k,) object ids (agent index + 1, as in the observation).
        xy: (k, 2) [m]; velocity: (k, 2) [m/s]; pos_std_m: (k,) sqrt of the mean position
            variance [m]; length_m, width_m: (k,) [m]; is_pedestrian: (k,) bool;
        seen: (k,) bool, measured this step; age_unseen_s: (k,) time since last measured [s].
        heading_rad: (k,) footprint heading [rad] (module docstring).
        velocity_change_cov: (k, 2, 2) covariance of the error of the tracked velocity change
            over the last step, (v_k - v_{k-1}) estimated minus true [m^2/s^2] (from the
            filter: P_k + P_{k-1} - C - C^T with C = Cov(e_k, e_{k-1}) = (I - K H) F P_{k-1},
            velocity block); divided by dt^2 it is the variance of an acceleration read off the
            track. None: not known (zero).
    """

    ids: np.ndarray
    xy: np.ndarray
    velocity: np.ndarray
    pos_std_m: np.ndarray
    length_m: np.ndarray
    width_m: np.ndarray
    is_pedestrian: np.ndarray
    seen: np.ndarray
    age_unseen_s: np.ndarray
    heading_rad: np.ndarray
    velocity_change_cov: np.ndarray | None = None

    def __len__(self) -> int:
        """Number of tracks k."""
        return len(self.ids)

    def predict_xy(self, times_s: np.ndarray) -> np.ndarray:
        """Constant-velocity prediction (k, T, 2) [m] at future times (T,) [s]."""
        return self.xy[:, None, :] + self.velocity[:, None, :] * times_s[None, :, None]


class Tracker:
    """Kalman-filter tracks of what one agent has seen.

    Args:
        pos_noise_m: position measurement noise std of the agent's sensor [m].
        vel_noise_mps: velocity measurement noise std [m/s].
        accel_noise_mps2: process noise (white acceleration) std [m/s^2].
        timeout_s: an unseen track is dropped after this long [s].
        dt_s: step length [s].
    """

    def __init__(self, pos_noise_m: float = 0.05, vel_noise_mps: float = 0.1,
                 accel_noise_mps2: float = 2.0, timeout_s: float = 2.0, dt_s: float = DT_S):
        """Build the constant-velocity model matrices and start with no tracks."""
        # imported here: filterpy.common pulls in scipy.stats (~0.4 s of `import marl_social`)
        from filterpy.common import Q_discrete_white_noise

        self.dt_s = dt_s
        self.timeout_s = timeout_s
        self._R = np.diag([max(pos_noise_m, MIN_NOISE_STD) ** 2] * 2
                          + [max(vel_noise_mps, MIN_NOISE_STD) ** 2] * 2)
        self._Q = Q_discrete_white_noise(dim=2, dt=dt_s, var=accel_noise_mps2 ** 2, block_size=2,
                                         order_by_dim=False)
        self._F = np.array([[1, 0, dt_s, 0], [0, 1, 0, dt_s], [0, 0, 1, 0], [0, 0, 0, 1.0]])
        model = (self._F.tobytes(), self._Q.tobytes(), self._R.tobytes())
        self._steps = _COVARIANCE_STEPS.setdefault(model, {})
        self.reset()

    def reset(self) -> None:
        """Drop every track."""
        self._filters: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # id -> (x (4,), P (4, 4))
        self._dv_cov: dict[int, np.ndarray] = {}  # id -> (2, 2) velocity-change error cov
        self._attrs: dict[int, tuple[float, float, bool, float]] = {}  # length, width, ped, psi
        self._unseen: dict[int, float] = {}
        self._seen_now: set[int] = set()

    _H = np.eye(4)

    def update(self, decoded: DecodedObservation) -> TrackSet:
        """Advance every track one step and fold in this step's measurements.

        Args:
            decoded: the agent's decoded observation (its present slots are the measurements).
        """
        objects = decoded.objects
        measured = {}
        for row in objects:
            oid = round(row[SLOT_INDEX["id"]])
            measured[oid] = row
        for oid in list(self._filters):
            x, p_prev = self._filters[oid]
            x_pred = dot(self._F, x) + 0  # kf_predict's state (F x + dot(B=1, u=0)), bit for bit
            gain, p_next, dv_cov = self._covariance_step(p_prev, oid in measured)
            if oid in measured:
                z = measured[oid][_MEASURED_STATE].astype(np.float64)
                x_pred = x_pred + dot(gain, z - dot(self._H, x_pred))  # kf_update's state
            else:
                self._unseen[oid] += self.dt_s
            self._filters[oid] = (x_pred, p_next)
            self._dv_cov[oid] = dv_cov
            if self._unseen[oid] > self.timeout_s:
                del self._filters[oid], self._attrs[oid], self._unseen[oid]
                del self._dv_cov[oid]
        for oid, row in measured.items():
            if oid not in self._filters:
                self._filters[oid] = (row[_MEASURED_STATE].astype(np.float64), self._R.copy())
                self._dv_cov[oid] = 2.0 * self._R[2:, 2:]
            self._attrs[oid] = (float(row[SLOT_INDEX["length"]]), float(row[SLOT_INDEX["width"]]),
                                bool(row[SLOT_INDEX["is_pedestrian"]] > 0.5),
                                float(np.arctan2(row[SLOT_INDEX["sin_psi"]],
                                                 row[SLOT_INDEX["cos_psi"]])))
            self._unseen[oid] = 0.0
        self._seen_now = set(measured)
        return self.tracks()

    def _covariance_step(self, p_prev: np.ndarray, measured: bool) -> tuple:
        """One step of a track's covariance, which does not depend on the measured values.

        With a fixed model (F, Q, R, H = I) the covariance sequence of a track depends only on
        whether it was measured at each step, so the steps are computed once per distinct
        covariance (by kf_predict / kf_update, bit for bit) and shared by every track and
        every tracker with the same model.

        Args:
            p_prev: (4, 4) covariance before the step.
            measured: whether the track is measured in this step.

        Returns:
            the Kalman gain (4, 4) (None when not measured), the covariance after the step
            (4, 4) and the velocity-change error covariance (2, 2) (`_velocity_change_cov`).
        """
        key = (p_prev.tobytes(), measured)
        step = self._steps.get(key)
        if step is None:
            zero = np.zeros(4)
            _, p_pred = kf_predict(zero, p_prev, self._F, self._Q)
            if measured:
                s_inv = np.linalg.inv(dot(dot(self._H, p_pred), self._H.T) + self._R)
                gain = dot(dot(p_pred, self._H.T), s_inv)
                _, p_next = kf_update(zero, p_pred, zero, self._R, self._H)
                step = (gain, p_next, self._velocity_change_cov(p_prev, p_pred))
            else:
                step = (None, p_pred, self._velocity_change_cov(p_prev, None))
            if len(self._steps) >= _MAX_COVARIANCE_STEPS:
                self._steps.clear()
            self._steps[key] = step
        return step

    def _velocity_change_cov(self, p_prev: np.ndarray, p_pred: np.ndarray | None) -> np.ndarray:
        """(2, 2) error covariance of the tracked velocity change over the last step [m^2/s^2].

        Args:
            p_prev: (4, 4) covariance before the step.
            p_pred: (4, 4) predicted covariance of this step (None: the track coasted).
        """
        if p_pred is None:
            gain_term = np.eye(4)
            p_new = self._F @ p_prev @ self._F.T + self._Q
        else:
            gain = p_pred @ np.linalg.inv(p_pred + self._R)  # K with H = I
            gain_term = np.eye(4) - gain
            p_new = gain_term @ p_pred
        cross = gain_term @ self._F @ p_prev  # Cov(e_k, e_{k-1})
        d = p_new + p_prev - cross - cross.T
        return 0.5 * (d[2:, 2:] + d[2:, 2:].T)

    def tracks(self) -> TrackSet:
        """The current tracks, ascending object id."""
        ids = np.array(sorted(self._filters), dtype=np.int64)
        if len(ids) == 0:
            z2 = np.zeros((0, 2))
            z0 = np.zeros(0)
            return TrackSet(ids, z2, z2, z0, z0, z0, np.zeros(0, bool), np.zeros(0, bool), z0,
                            z0, np.zeros((0, 2, 2)))
        states = np.array([self._filters[i][0] for i in ids])
        pos_var = np.array([0.5 * (self._filters[i][1][0, 0] + self._filters[i][1][1, 1])
                            for i in ids])
        attrs = np.array([self._attrs[i] for i in ids], dtype=np.float64)
        return TrackSet(
            ids, states[:, :2], states[:, 2:], np.sqrt(pos_var), attrs[:, 0], attrs[:, 1],
            attrs[:, 2] > 0.5, np.array([i in self._seen_now for i in ids]),
            np.array([self._unseen[i] for i in ids]), track_heading(states[:, 2:], attrs[:, 3]),
            np.array([self._dv_cov[i] for i in ids]),
        )


def track_heading(velocity_mps: np.ndarray, measured_heading_rad: np.ndarray) -> np.ndarray:
    """(k,) footprint headings [rad]: the velocity's direction when moving, else the box's.

    Args:
        velocity_mps: (k, 2) tracked velocities [m/s]; the direction counts from MOVING_MPS.
        measured_heading_rad: (k,) last measured box headings [rad].
    """
    speed = np.hypot(velocity_mps[:, 0], velocity_mps[:, 1])
    return np.where(speed >= MOVING_MPS, np.arctan2(velocity_mps[:, 1], velocity_mps[:, 0]),
                    measured_heading_rad)
