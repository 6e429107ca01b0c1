"""Kinematic bicycle and pedestrian dynamics."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.sim.dynamics import (
    DT_S,
    bicycle_step,
    pedestrian_step,
    saturate_pedestrian_action,
    saturate_vehicle_action,
)

WB = np.array([2.7])
VMAX = np.array([20.0])


def _drive(state, action, steps):
    s = np.array([state], dtype=float)
    for _ in range(steps):
        s = bicycle_step(s, np.array([action], dtype=float), WB, VMAX)
    return s[0]


def test_straight_line_constant_speed():
    s = _drive([0, 0, 0, 10.0], [0, 0], 10)
    assert s == pytest.approx([10.0, 0.0, 0.0, 10.0])


def test_braking_stops_at_the_kinematic_distance_and_never_reverses():
    s = _drive([0, 0, 0, 10.0], [-5.0, 0], 40)
    assert s[3] == 0.0
    assert s[0] == pytest.approx(10.0 ** 2 / (2 * 5.0), abs=1e-9)


def test_constant_steer_follows_the_bicycle_circle():
    delta = 0.1
    v = 5.0
    s = np.array([[0, 0, 0, v]], dtype=float)
    pts = []
    for _ in range(400):
        s = bicycle_step(s, np.array([[0.0, delta]]), WB, VMAX, dt_s=0.01)
        pts.append(s[0, :2].copy())
    pts = np.array(pts)
    # the reference point moves on a circle of radius L / (cos(beta) tan(delta)) about the
    # instantaneous centre; fit the circle and compare
    beta = np.arctan(0.5 * np.tan(delta))
    radius = 2.7 / (np.cos(beta) * np.tan(delta))
    a = np.column_stack([2 * pts, np.ones(len(pts))])
    b = np.sum(pts ** 2, axis=1)
    cx, cy, c = np.linalg.lstsq(a, b, rcond=None)[0]
    fitted = np.sqrt(c + cx ** 2 + cy ** 2)
    assert fitted == pytest.approx(radius, rel=1e-3)


def test_vehicle_saturation():
    out = saturate_vehicle_action(np.array([[10.0, 1.0], [-10.0, -1.0]]), np.array([1.0, 20.0]),
                                  np.array([2.7, 2.7]), np.array([3.0, 3.0]),
                                  np.array([8.0, 8.0]), np.array([0.6, 0.6]),
                                  np.array([6.0, 6.0]))
    assert out[0] == pytest.approx([3.0, 0.6])  # slow: the steering limit binds
    assert out[1, 0] == -8.0
    assert out[1, 1] == pytest.approx(-np.arctan(2.7 * 6.0 / 400.0))  # fast: G-G binds


def test_pedestrian_moves_by_command_and_saturates():
    cmd = saturate_pedestrian_action(np.array([[3.0, 4.0], [0.5, 0.0]]), np.array([2.0, 2.0]))
    assert np.linalg.norm(cmd[0]) == pytest.approx(2.0)
    assert cmd[1] == pytest.approx([0.5, 0.0])
    s = pedestrian_step(np.array([[0.0, 0.0, 1.0, 0.0], [0, 0, 1.0, 0]]),
                        np.array([[0.0, 1.5], [0.0, 0.0]]))
    assert s[0] == pytest.approx([0.0, 0.15, np.pi / 2, 1.5])
    assert s[1, 2] == 1.0  # standing still keeps the heading


def test_written_out_clips_and_norms_equal_numpy_s_bit_for_bit():
    """The dynamics spell out clip and norm for speed; the values are numpy's, exactly."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        n = int(rng.integers(1, 12))
        act = rng.normal(0, 3, (n, 2)) * 10.0 ** rng.integers(-3, 3, (n, 1))
        act[rng.random((n, 2)) < 0.2] = 0.0
        speed = np.where(rng.random(n) < 0.2, 0.0, rng.uniform(0, 20, n))
        wb, a_max, b_max = rng.uniform(2, 3, n), rng.uniform(1, 4, n), rng.uniform(3, 9, n)
        s_max, lat, v_max = rng.uniform(0.3, 0.7, n), rng.uniform(3, 8, n), rng.uniform(1, 30, n)
        sat = saturate_vehicle_action(act, speed, wb, a_max, b_max, s_max, lat)
        lim = np.minimum(s_max, np.arctan(wb * lat / np.maximum(speed, 1e-3) ** 2))
        ref = np.stack([np.clip(act[:, 0], -b_max, a_max), np.clip(act[:, 1], -lim, lim)], 1)
        assert sat.tobytes() == ref.tobytes()
        state = np.column_stack([rng.normal(0, 50, (n, 2)), rng.uniform(-4, 4, n), speed])
        nxt = bicycle_step(state, sat, wb, v_max)
        assert nxt[:, 3].tobytes() == np.clip(speed + sat[:, 0] * DT_S, 0.0, v_max).tobytes()
        ped = saturate_pedestrian_action(act, v_max)
        norm = np.linalg.norm(act, axis=1)
        scale = np.where(norm > v_max, v_max / np.maximum(norm, 1e-12), 1.0)
        assert ped.tobytes() == (act * scale[:, None]).tobytes()
        assert pedestrian_step(state, ped)[:, 3].tobytes() == np.linalg.norm(ped, axis=1).tobytes()
