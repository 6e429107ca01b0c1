"""Kalman-filter tracks built only from an agent's own noisy observations."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.perception.tracking import Tracker, white_noise_q
from marl_social.sim.observation import EGO_DIM, SLOT_FIELDS, SLOT_INDEX, ObservationLayout
from tests.helpers import slot_observation

LAYOUT = ObservationLayout(n_slots=4, n_rays=4)
F = SLOT_INDEX


def _obs(objects):
    """An observation vector with the given objects: (id, x, y, vx, vy) tuples."""
    return slot_observation(LAYOUT, objects)


def test_track_filters_noise_towards_the_true_motion():
    rng = np.random.default_rng(0)
    tracker = Tracker(pos_noise_m=0.5, vel_noise_mps=1.0)
    raw_err, kf_err, raw_verr, kf_verr = [], [], [], []
    for k in range(60):
        true = np.array([10.0 + 0.1 * k * 8.0, 2.0])
        meas = true + rng.normal(0, 0.5, 2)
        vel = np.array([8.0, 0.0]) + rng.normal(0, 1.0, 2)
        tracks = tracker.update(_obs([(3, *meas, *vel)]))
        if k >= 20:
            raw_err.append(np.linalg.norm(meas - true))
            kf_err.append(np.linalg.norm(tracks.xy[0] - true))
            raw_verr.append(np.linalg.norm(vel - [8.0, 0.0]))
            kf_verr.append(np.linalg.norm(tracks.velocity[0] - [8.0, 0.0]))
    assert np.mean(kf_err) < 0.6 * np.mean(raw_err)
    assert np.mean(kf_verr) < 0.8 * np.mean(raw_verr)


def test_unseen_track_coasts_then_is_dropped():
    tracker = Tracker(timeout_s=1.0)
    for k in range(10):
        tracker.update(_obs([(2, 5.0 + k, 0.0, 10.0, 0.0)]))
    seen = tracker.tracks()
    assert seen.seen[0] and seen.age_unseen_s[0] == 0.0
    x_last = seen.xy[0, 0]
    for _ in range(5):  # hidden for 0.5 s: the track coasts on at ~10 m/s
        coast = tracker.update(_obs([]))
    assert list(coast.ids) == [2] and not coast.seen[0]
    assert coast.xy[0, 0] == pytest.approx(x_last + 0.5 * 10.0, abs=0.3)
    assert coast.pos_std_m[0] > seen.pos_std_m[0]  # uncertainty grows while coasting
    for _ in range(6):  # past the 1 s timeout
        gone = tracker.update(_obs([]))
    assert len(gone) == 0


def test_new_objects_get_their_own_tracks_in_id_order():
    tracker = Tracker()
    tracks = tracker.update(_obs([(5, 0, 0, 0, 0), (2, 10, 0, 1, 0)]))
    assert list(tracks.ids) == [2, 5]
    assert tracks.xy[0] == pytest.approx([10, 0])


def test_velocity_change_covariance_matches_the_track_error():
    """TrackSet.velocity_change_cov / dt^2 is (conservatively) the variance of an acceleration
    read off the track of a car at constant speed, for a precise and a noisy sensor."""

    layout = ObservationLayout(n_slots=2, n_rays=4)
    fields = [SLOT_INDEX[f] for f in ("present", "id", "x", "y", "vx", "cos_psi", "length",
                                      "width")]
    for pos_noise in (0.05, 1.0):
        tracker = Tracker(pos_noise_m=pos_noise, vel_noise_mps=0.1, accel_noise_mps2=1.5)
        rng = np.random.default_rng(0)
        speed, predicted = [], []
        for k in range(400):
            obs = np.zeros(layout.size)
            obs[EGO_DIM + np.array(fields)] = [
                1, 2, 1.0 * k + pos_noise * rng.standard_normal(),
                pos_noise * rng.standard_normal(), 10.0 + 0.1 * rng.standard_normal(), 1, 4.5, 1.8]
            tracks = tracker.update(layout.decode(obs))
            speed.append(tracks.velocity[0, 0])
            predicted.append(math.sqrt(tracks.velocity_change_cov[0, 0, 0]) / 0.1)
        empirical = np.std(np.diff(speed[20:]) / 0.1)
        assert empirical <= predicted[-1] <= 1.5 * empirical, (pos_noise, empirical)


def test_inlined_kalman_steps_are_filterpy_bit_for_bit():
    from filterpy.kalman import predict, update

    from marl_social.perception.tracking import kf_predict, kf_update

    rng = np.random.default_rng()
    tracker = Tracker(pos_noise_m=rng.uniform(0.01, 1.0), vel_noise_mps=rng.uniform(0.01, 1.0))
    F, Q, R, H = tracker._F, tracker._Q, tracker._R, tracker._H
    x, P = rng.normal(0, 20, 4), tracker._R.copy()
    x[rng.integers(4)] = -0.0  # signed zeros must come out the same too
    for _ in range(200):
        a, b = kf_predict(x, P, F, Q), predict(x, P, F, Q)
        assert all(np.array_equal(u, v) and np.array_equal(np.signbit(u), np.signbit(v))
                   for u, v in zip(a, b))
        x, P = a
        z = x + rng.normal(0, 1, 4)
        a, b = kf_update(x, P, z, R, H), update(x, P, z, R, H)
        assert all(np.array_equal(u, v) and np.array_equal(np.signbit(u), np.signbit(v))
                   for u, v in zip(a, b))
        x, P = a


class _PerTrackReference:
    """The tracker as it was before its tracks' states became Python floats: one filter per
    track, np.dot for every product (kf_predict / kf_update's state arithmetic)."""

    def __init__(self, tracker: Tracker):
        self.t = tracker
        self.filters, self.dv_cov, self.attrs, self.unseen = {}, {}, {}, {}

    def update(self, decoded):
        from numpy import dot

        t = self.t
        measured = {round(row[F["id"]]): row for row in decoded.objects}
        seen = set(measured)
        for oid in list(self.filters):
            x, p_prev = self.filters[oid]
            x_pred = dot(t._F, x) + 0
            gain, p_next, dv_cov = t._covariance_step(p_prev, oid in measured)
            if oid in measured:
                z = measured[oid][F["x"]:F["vy"] + 1].astype(np.float64)
                x_pred = x_pred + dot(gain, z - dot(t._H, x_pred))
            else:
                self.unseen[oid] += t.dt_s
            self.filters[oid], self.dv_cov[oid] = (x_pred, p_next), dv_cov
            if self.unseen[oid] > t.timeout_s:
                del self.filters[oid], self.attrs[oid], self.unseen[oid], self.dv_cov[oid]
        for oid, row in measured.items():
            if oid not in self.filters:
                self.filters[oid] = (row[F["x"]:F["vy"] + 1].astype(np.float64), t._R.copy())
                self.dv_cov[oid] = 2.0 * t._R[2:, 2:]
            self.attrs[oid] = (float(row[F["length"]]), float(row[F["width"]]),
                               bool(row[F["is_pedestrian"]] > 0.5),
                               float(np.arctan2(row[F["sin_psi"]], row[F["cos_psi"]])))
            self.unseen[oid] = 0.0
        ids = sorted(self.filters)
        if not ids:
            return None
        states = np.array([self.filters[i][0] for i in ids])
        attrs = np.array([self.attrs[i] for i in ids], dtype=np.float64)
        from marl_social.perception.tracking import track_heading
        return dict(  # noqa: C408
            ids=np.array(ids), xy=states[:, :2], velocity=states[:, 2:],
            pos_std_m=np.sqrt([0.5 * (self.filters[i][1][0, 0] + self.filters[i][1][1, 1])
                               for i in ids]),
            length_m=attrs[:, 0], width_m=attrs[:, 1], is_pedestrian=attrs[:, 2] > 0.5,
            seen=np.array([i in seen for i in ids]),
            age_unseen_s=np.array([self.unseen[i] for i in ids]),
            heading_rad=track_heading(states[:, 2:], attrs[:, 3]),
            velocity_change_cov=np.array([self.dv_cov[i] for i in ids]))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_tracks_are_the_per_track_filters_bit_for_bit(dtype):
    """Random scenes (objects appearing, hidden, timed out, repeated slots, zeros and signed
    zeros, pedestrians, stopped objects): every TrackSet field has the reference's bits."""
    rng = np.random.default_rng(7)
    layout = ObservationLayout(n_slots=5, n_rays=2)
    for trial in range(12):
        tracker = Tracker(pos_noise_m=rng.uniform(0.0, 1.0), vel_noise_mps=rng.uniform(0.0, 1.0),
                          accel_noise_mps2=rng.uniform(0.5, 3.0), timeout_s=rng.uniform(0.3, 2.0))
        reference = _PerTrackReference(tracker)
        for step in range(60):
            obs = np.zeros(layout.size, dtype=dtype)
            n = rng.integers(0, 6)
            oids = rng.choice(np.arange(1, 8), size=n, replace=rng.random() < 0.8)
            for k, oid in enumerate(oids):
                base = EGO_DIM + k * len(SLOT_FIELDS)
                values = rng.normal(0, 20, 4) * (rng.random(4) < 0.8)
                values[rng.random(4) < 0.1] = -0.0
                heading = rng.uniform(-np.pi, np.pi)
                obs[base:base + len(SLOT_FIELDS)] = [
                    1.0, oid, *values, math.cos(heading), math.sin(heading), 4.5, 1.8,
                    float(rng.random() < 0.3)]
            decoded = layout.decode(obs)
            got, want = tracker.update(decoded), reference.update(decoded)
            if want is None:
                assert len(got) == 0
                continue
            for name, value in want.items():
                have = getattr(got, name)
                assert have.dtype == value.dtype and have.shape == value.shape, name
                assert np.array_equal(have, value, equal_nan=True), (trial, step, name)
                if value.dtype.kind == "f":
                    assert np.array_equal(np.signbit(have), np.signbit(value)), (trial, name)
            assert got.ids.dtype == np.int64


def _reference_covariance_step(t: Tracker, p_prev, measured):
    """The covariance step as kf_predict / kf_update and a separate inverse compute it."""
    from marl_social.perception.tracking import kf_predict, kf_update

    zero = np.zeros(4)
    _, p_pred = kf_predict(zero, p_prev, t._F, t._Q)
    if measured:
        gain = np.dot(np.dot(p_pred, t._H.T),
                      np.linalg.inv(np.dot(np.dot(t._H, p_pred), t._H.T) + t._R))
        _, p_next = kf_update(zero, p_pred, zero, t._R, t._H)
        gain_term = np.eye(4) - p_pred @ np.linalg.inv(p_pred + t._R)
        p_new = gain_term @ p_pred
    else:
        gain, p_next = None, p_pred
        gain_term = np.eye(4)
        p_new = t._F @ p_prev @ t._F.T + t._Q
    cross = gain_term @ t._F @ p_prev
    d = p_new + p_prev - cross - cross.T
    return gain, p_next, 0.5 * (d[2:, 2:] + d[2:, 2:].T)


def test_covariance_steps_are_kf_predict_and_kf_update_bit_for_bit():
    rng = np.random.default_rng(11)
    for _ in range(20):
        tracker = Tracker(pos_noise_m=rng.uniform(0.0, 1.0), vel_noise_mps=rng.uniform(0.0, 1.0),
                          accel_noise_mps2=rng.uniform(0.5, 3.0))
        p = tracker._R.copy()
        for _ in range(60):
            measured = bool(rng.random() < 0.7)
            got = tracker._covariance_step(p, measured)
            want = _reference_covariance_step(tracker, p, measured)
            for a, b in zip(got, want):
                assert (a is None) == (b is None)
                if a is not None:
                    assert a.tobytes() == b.tobytes()
            p = got[1]


def test_copied_and_pickled_trackers_go_on_bit_for_bit():
    """A tracker with long covariance chains deep-copies and pickles (the nodes are shared, or
    pickled as their covariances) and its copies go on exactly as it does."""
    import copy
    import pickle

    rng = np.random.default_rng(5)
    tracker = Tracker()
    steps = [_obs([(2, k, 0.0, 10.0 + rng.normal(), 0.0)] if k % 7 else []) for k in range(150)]
    for decoded in steps[:120]:
        tracker.update(decoded)
    copies = [copy.deepcopy(tracker), pickle.loads(pickle.dumps(tracker))]
    for decoded in steps[120:]:
        want = tracker.update(decoded)
        for other in copies:
            got = other.update(decoded)
            for name in want.__dataclass_fields__:
                assert np.array_equal(getattr(got, name), getattr(want, name)), name


@settings(max_examples=300, deadline=None)
@given(dt_s=st.floats(1e-4, 2.0), var=st.floats(0.0, 1e4))
def test_white_noise_q_is_filterpys_bit_for_bit(dt_s, var):
    from filterpy.common import Q_discrete_white_noise

    expected = Q_discrete_white_noise(dim=2, dt=dt_s, var=var, block_size=2,
                                      order_by_dim=False)
    got = white_noise_q(dt_s, var)
    assert got.dtype == expected.dtype and got.tobytes() == expected.tobytes()


def test_a_tracker_does_not_import_filterpy_or_scipy_stats():
    """Building and updating a tracker costs no scipy.stats import (~1 s per process)."""
    code = ("import sys\n"
            "from marl_social.perception.tracking import Tracker\n"
            "Tracker().tracks()\n"
            "print(sorted(m for m in ('filterpy', 'scipy.stats') if m in sys.modules))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert done.stdout.strip() == "[]"
