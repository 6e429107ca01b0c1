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
# covariance nodes shared by trackers of one model (_CovarianceNode), per model: covariance bytes
# -> node; a table is emptied when it reaches this many entries
_MAX_COVARIANCE_STEPS = 4096
_MAX_CHAIN_STEPS = 400  # Tracker._measured_chain stops here should it not reach a fixed point
_COVARIANCE_NODES: dict[tuple, dict] = {}
# slot columns of the measured state [x m, y m, vx m/s, vy m/s]
# (consecutive in SLOT_FIELDS)
_MEASURED_STATE = slice(SLOT_INDEX["x"], SLOT_INDEX["vy"] + 1)
_PRESENT, _ID, _X, _VY = SLOT_INDEX["present"], SLOT_INDEX["id"], SLOT_INDEX["x"], SLOT_INDEX["vy"]
_LENGTH, _WIDTH = SLOT_INDEX["length"], SLOT_INDEX["width"]
_IS_PEDESTRIAN = SLOT_INDEX["is_pedestrian"]
_SIN_PSI, _COS_PSI = SLOT_INDEX["sin_psi"], SLOT_INDEX["cos_psi"]


def white_noise_q(dt_s: float, var: float) -> np.ndarray:
    """(4, 4) process noise of the constant-velocity model [x, y, vx, vy] (white acceleration).

    `filterpy.common.Q_discrete_white_noise(dim=2, dt=dt_s, var=var, block_size=2,
    order_by_dim=False)`, the same operations, bit for bit (tests/perception/test_tracking.py):
    importing filterpy runs its package's __init__, which imports scipy.stats, ~1 s of every
    process that builds a tracker.

    Args:
        dt_s: step length [s].
        var: variance of the white acceleration [m^2/s^4].
    """
    per_axis = np.array([[.25 * dt_s ** 4, .5 * dt_s ** 3],
                         [.5 * dt_s ** 3, dt_s ** 2]])
    return np.kron(per_axis, np.eye(2)) * var  # filterpy's order_by_derivative, then * var


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
        velocity_cov: (k, 2, 2) covariance of the tracked velocity's error [m^2/s^2] (the
            filter's velocity block). None: not known.
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
    velocity_cov: np.ndarray | None = None

    def __len__(self) -> int:
        """Number of tracks k."""
        return len(self.ids)

    def predict_xy(self, times_s: np.ndarray) -> np.ndarray:
        """Constant-velocity prediction (k, T, 2) [m] at future times (T,) [s]."""
        return self.xy[:, None, :] + self.velocity[:, None, :] * times_s[None, :, None]


class _CovarianceNode:
    """One covariance of a track and its two possible steps, shared by the tracks of a model.

    With a fixed model (F, Q, R, H = I) the covariance sequence of a track depends only on
    whether it was measured at each step: a track keeps the node of its current covariance,
    and each step of a node is computed once (Tracker._covariance_step) and then followed.

    Attributes:
        p: (4, 4) the covariance.
        pos_std_m: sqrt of its mean position variance [m] (TrackSet.pos_std_m).
        steps: [coasting, measured] -> (Kalman gain (4, 4) or None when coasting, the node
            after the step, the step's velocity-change error covariance (2, 2)); None: not
            computed yet.
    """

    __slots__ = ("p", "pos_std_m", "steps")

    def __init__(self, p: np.ndarray):
        self.p = p
        self.pos_std_m = float(np.sqrt(0.5 * (p[0, 0] + p[1, 1])))
        self.steps: list = [None, None]

    def __deepcopy__(self, memo: dict) -> _CovarianceNode:
        """Itself: a shared entry of a cache (copying a tracker shares its nodes)."""
        return self

    def __reduce__(self) -> tuple:
        """Pickled as its covariance alone (its steps are computed again where needed).

        The nodes form chains (~90 steps to a fixed point) deeper than pickle's recursion.
        """
        return _CovarianceNode, (self.p,)


class Tracker:
    """Kalman-filter tracks of what one agent has seen.

    A track's state is kept as four Python floats and predicted and updated with kf_predict's
    and kf_update's matrix products written out (each row's four products summed left to right:
    the same sums as np.dot of a (4, 4) and a (4,), tests/perception/test_tracking.py); its
    covariance is a shared
    `_CovarianceNode`.

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
        self.dt_s = dt_s
        self.timeout_s = timeout_s
        self._R = np.diag([max(pos_noise_m, MIN_NOISE_STD) ** 2] * 2
                          + [max(vel_noise_mps, MIN_NOISE_STD) ** 2] * 2)
        self._Q = white_noise_q(dt_s, accel_noise_mps2 ** 2)
        self._F = np.array([[1, 0, dt_s, 0], [0, 1, 0, dt_s], [0, 0, 1, 0], [0, 0, 0, 1.0]])
        model = (self._F.tobytes(), self._Q.tobytes(), self._R.tobytes())
        self._nodes = _COVARIANCE_NODES.setdefault(model, {})
        self._root = self._node(self._R.copy())  # a new track's covariance
        self._new_track_dv_cov = 2.0 * self._R[2:, 2:]
        self._f_rows, self._h_rows = self._F.tolist(), self._H.tolist()
        self._measured_chain()
        self.reset()

    def reset(self) -> None:
        """Drop every track."""
        # id -> [state [x m, y m, vx m/s, vy m/s] (Python floats), covariance node,
        # velocity-change error covariance (2, 2), time unseen [s]]
        self._tracks: dict[int, list] = {}
        # id -> last measured (length m, width m, is_pedestrian 1.0 / 0.0, box heading rad)
        self._attrs: dict[int, tuple] = {}
        self._seen_now: set[int] = set()

    _H = np.eye(4)

    def update(self, decoded: DecodedObservation) -> TrackSet:
        """Advance every track one step and fold in this step's measurements.

        Args:
            decoded: the agent's decoded observation (its present slots are the measurements).
        """
        slots = decoded.slots
        rows = slots.tolist()  # float32 -> float: exact
        # object id -> the row of its present slot (the last one, should an id repeat);
        # row[_PRESENT] > 0.5 is DecodedObservation.objects' test, in float64 the same
        measured = {round(row[_ID]): k for k, row in enumerate(rows) if row[_PRESENT] > 0.5}
        f_rows, h_rows = self._f_rows, self._h_rows
        for oid in list(self._tracks):
            track = self._tracks[oid]
            x, node = track[0], track[1]
            k = measured.get(oid)
            row = None if k is None else rows[k]
            step = node.steps[row is not None]
            if step is None:
                step = node.steps[row is not None] = self._node_step(node.p, row is not None)
            gain_rows, track[1], track[2] = step
            # kf_predict's state F x + 0 (np.dot of a (4, 4) and a (4,): the same sums in the
            # same order, tests/perception/test_tracking.py), row by row on Python floats
            x0, x1, x2, x3 = x
            x = [m0 * x0 + m1 * x1 + m2 * x2 + m3 * x3 + 0 for m0, m1, m2, m3 in f_rows]
            if row is not None:  # kf_update's state x + K (z - H x)
                x0, x1, x2, x3 = x
                i0, i1, i2, i3 = (z - (m0 * x0 + m1 * x1 + m2 * x2 + m3 * x3)
                                  for z, (m0, m1, m2, m3) in zip(row[_X:_VY + 1], h_rows))
                x = [value + (m0 * i0 + m1 * i1 + m2 * i2 + m3 * i3)
                     for value, (m0, m1, m2, m3) in zip(x, gain_rows)]
            else:
                track[3] += self.dt_s
                if track[3] > self.timeout_s:
                    del self._tracks[oid], self._attrs[oid]
                    continue
            track[0] = x
        if measured:
            # np.arctan2 of every slot's (strided) columns: element by element what it gives
            # for the present rows alone
            headings = np.arctan2(slots[:, _SIN_PSI], slots[:, _COS_PSI]).tolist()
            for oid, k in measured.items():
                row = rows[k]
                track = self._tracks.get(oid)
                if track is None:
                    self._tracks[oid] = [row[_X:_VY + 1], self._root, self._new_track_dv_cov,
                                         0.0]
                else:
                    track[3] = 0.0
                self._attrs[oid] = (row[_LENGTH], row[_WIDTH], float(row[_IS_PEDESTRIAN] > 0.5),
                                    headings[k])
        self._seen_now = set(measured)
        return self.tracks()

    def _measured_chain(self) -> None:
        """Compute the covariance steps of a track measured at every step, once per model.

        The chain from R reaches its fixed point (a step to the same covariance) in about 90
        steps; every new track walks it, so it is computed here rather than within decisions.
        """
        node = self._root
        for _ in range(_MAX_CHAIN_STEPS):
            step = node.steps[True]
            if step is None:
                step = node.steps[True] = self._node_step(node.p, True)
            if step[1] is node:
                return
            node = step[1]

    def _node(self, p: np.ndarray) -> _CovarianceNode:
        """The shared node of covariance `p` (4, 4) (emptied at _MAX_COVARIANCE_STEPS nodes)."""
        key = p.tobytes()
        node = self._nodes.get(key)
        if node is None:
            if len(self._nodes) >= _MAX_COVARIANCE_STEPS:
                self._nodes.clear()
            node = self._nodes[key] = _CovarianceNode(p)
        return node

    def _node_step(self, p_prev: np.ndarray, measured: bool) -> tuple:
        """_covariance_step of `p_prev`, for a `_CovarianceNode`'s steps.

        Returns:
            the gain's rows as floats (None: coasting), the node of the covariance after the
            step and the velocity-change error covariance (2, 2).
        """
        gain, p_next, dv_cov = self._covariance_step(p_prev, measured)
        return None if gain is None else gain.tolist(), self._node(p_next), dv_cov

    def _covariance_step(self, p_prev: np.ndarray, measured: bool) -> tuple:
        """One step of a track's covariance, which does not depend on the measured values.

        kf_predict's and kf_update's covariance arithmetic, bit for bit, each matrix computed
        once (tests/perception/test_tracking.py).

        Args:
            p_prev: (4, 4) covariance before the step.
            measured: whether the track is measured in this step.

        Returns:
            the Kalman gain (4, 4) (None when not measured), the covariance after the step
            (4, 4) and the velocity-change error covariance (2, 2) (`_velocity_change_cov`).
        """
        # kf_predict's covariance (its state, F 0 + 0, is not needed)
        p_pred = (1 * 1) * dot(dot(self._F, p_prev), self._F.T) + self._Q
        if not measured:
            return None, p_pred, self._velocity_change_cov(p_prev, None)
        # kf_update's covariance: its S, its K (the same operations as its own), Joseph form
        s = dot(dot(self._H, p_pred), self._H.T) + self._R
        s_inv = np.linalg.inv(s)
        gain = dot(dot(p_pred, self._H.T), s_inv)
        i_kh = np.eye(4) - dot(gain, self._H)
        p_next = dot(dot(i_kh, p_pred), i_kh.T) + dot(dot(gain, self._R), gain.T)
        return gain, p_next, self._velocity_change_cov(p_prev, p_pred, (s, s_inv))

    def _velocity_change_cov(self, p_prev: np.ndarray, p_pred: np.ndarray | None,
                             known_inverse: tuple | None = None) -> np.ndarray:
        """(2, 2) error covariance of the tracked velocity change over the last step [m^2/s^2].

        Args:
            p_prev: (4, 4) covariance before the step.
            p_pred: (4, 4) predicted covariance of this step (None: the track coasted).
            known_inverse: (a matrix, np.linalg.inv of it): reused when p_pred + R has the
                same bytes (the same inverse; with H = I, S of the update is usually that sum).
        """
        if p_pred is None:
            gain_term = np.eye(4)
            p_new = self._F @ p_prev @ self._F.T + self._Q
        else:
            s = p_pred + self._R
            if known_inverse is not None and s.tobytes() == known_inverse[0].tobytes():
                s_inv = known_inverse[1]
            else:
                s_inv = np.linalg.inv(s)
            gain = p_pred @ s_inv  # K with H = I
            gain_term = np.eye(4) - gain
            p_new = gain_term @ p_pred
        cross = gain_term @ self._F @ p_prev  # Cov(e_k, e_{k-1})
        d = p_new + p_prev - cross - cross.T
        return 0.5 * (d[2:, 2:] + d[2:, 2:].T)

    def tracks(self) -> TrackSet:
        """The current tracks, ascending object id."""
        if not self._tracks:
            return _NO_TRACKS
        ids = sorted(self._tracks)
        tracks = [self._tracks[i] for i in ids]
        attrs = [self._attrs[i] for i in ids]
        seen = self._seen_now
        # one row per track: state (4), position std, length, width, time unseen, measured box
        # heading; and two rows of flags: is_pedestrian, seen
        table = np.array([[*track[0], track[1].pos_std_m, attr[0], attr[1], track[3], attr[3]]
                          for track, attr in zip(tracks, attrs)])
        flags = np.array([[attr[2] > 0.5 for attr in attrs], [i in seen for i in ids]])
        velocity = table[:, 2:4]
        return TrackSet(
            np.array(ids, dtype=np.int64), table[:, 0:2], velocity, table[:, 4], table[:, 5],
            table[:, 6], flags[0], flags[1], table[:, 7],
            track_heading(velocity, table[:, 8]), np.array([track[2] for track in tracks]),
            np.array([track[1].p[2:4, 2:4] for track in tracks]),
        )


# the TrackSet of no tracks (its arrays hold nothing: sharing it is safe)
_NO_TRACKS = TrackSet(np.zeros(0, dtype=np.int64), np.zeros((0, 2)), np.zeros((0, 2)),
                      np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, bool),
                      np.zeros(0, bool), np.zeros(0), np.zeros(0), np.zeros((0, 2, 2)),
                      np.zeros((0, 2, 2)))


def track_heading(velocity_mps: np.ndarray, measured_heading_rad: np.ndarray) -> np.ndarray:
    """(k,) footprint headings [rad]: the velocity's direction when moving, else the box's.

    Args:
        velocity_mps: (k, 2) tracked velocities [m/s]; the direction counts from MOVING_MPS.
        measured_heading_rad: (k,) last measured box headings [rad].
    """
    speed = np.hypot(velocity_mps[:, 0], velocity_mps[:, 1])
    return np.where(speed >= MOVING_MPS, np.arctan2(velocity_mps[:, 1], velocity_mps[:, 0]),
                    measured_heading_rad)
