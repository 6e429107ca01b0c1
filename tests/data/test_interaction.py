"""INTERACTION-schema track files -> demonstrations (marl_social/data/interaction/).

The files are generated here: a car on a known curved path with a known acceleration profile
and 5 cm Gaussian position noise, other cars and pedestrians around it."""

from __future__ import annotations

import csv
import math
from types import SimpleNamespace

import numpy as np
import pytest

from marl_social.data.demonstrations import load_demonstrations, save_demonstrations
from marl_social.data.interaction import (
    BASE_COLUMNS,
    CSV_COLUMNS,
    PEDESTRIAN_DIAMETER_M,
    SegmentCut,
    fit_track,
    interaction_demonstrations,
    load_interaction,
    read_interaction_csv,
    replay,
    smooth_arc_length,
)
from marl_social.sim.road_map import Route

DT = 0.1
NOISE_M = 0.05
R_CURVE, L_STRAIGHT = 30.0, 30.0


def true_path(s):
    """Straight along +x for 30 m, a left quarter circle of radius 30 m, straight along +y
    (straight beyond both ends): (..., 2) [m] at arc length s (...) [m]."""
    s = np.asarray(s, dtype=np.float64)
    arc = 0.5 * math.pi * R_CURVE
    phi = np.clip((s - L_STRAIGHT) / R_CURVE, 0.0, 0.5 * math.pi)
    x = np.where(s < L_STRAIGHT, s, np.where(s < L_STRAIGHT + arc,
                                              L_STRAIGHT + R_CURVE * np.sin(phi),
                                              L_STRAIGHT + R_CURVE))
    y = np.where(s < L_STRAIGHT, 0.0, np.where(s < L_STRAIGHT + arc, R_CURVE * (1 - np.cos(phi)),
                                                R_CURVE + s - L_STRAIGHT - arc))
    return np.stack([x, y], axis=-1)


def true_heading(s):
    s = np.asarray(s, dtype=np.float64)
    return np.clip((s - L_STRAIGHT) / R_CURVE, 0.0, 0.5 * math.pi)


def kinematics(knots_t, knots_a, v0, duration_s):
    """Piecewise-linear acceleration through the knots, integrated exactly on a 1 ms grid:
    t (K,), a (K,), v (K,), s (K,) at the 10 Hz samples."""
    fine = np.arange(0.0, duration_s + 1e-9, 1e-3)
    a = np.interp(fine, knots_t, knots_a)
    v = v0 + np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * 1e-3)])
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * 1e-3)])
    idx = np.arange(0, len(fine), 100)
    return fine[idx], a[idx], v[idx], s[idx]


# accelerate at +1.5 m/s^2, then brake at -2.5 m/s^2 (1 s jerk-limited transitions)
CURVE_KNOTS = ((0, 1, 1.5, 5, 6, 9, 9.5, 14), (0, 0, 1.5, 1.5, -2.5, -2.5, 0, 0))


def car_rows(track_id, t, xy, heading, speed, first_frame=1, length=4.5, width=1.9):
    frames = first_frame + np.arange(len(t))
    return [[track_id, int(f), int(f) * 100, "car", f"{p[0]:.3f}", f"{p[1]:.3f}",
             f"{v * math.cos(h):.3f}", f"{v * math.sin(h):.3f}", f"{h:.4f}", length, width]
            for f, p, h, v in zip(frames, xy, heading, speed)]


def ped_rows(track_id, xy, vxy, first_frame=1):
    frames = first_frame + np.arange(len(xy))
    return [[track_id, int(f), int(f) * 100, "pedestrian/bicycle", f"{p[0]:.3f}", f"{p[1]:.3f}",
             f"{w[0]:.3f}", f"{w[1]:.3f}"] for f, p, w in zip(frames, xy, vxy)]


def write_csv(path, rows, columns=CSV_COLUMNS):
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(columns)
        writer.writerows(rows)
    return path


@pytest.fixture
def curved(tmp_path):
    """The curved car (track 1) with 5 cm position noise: file `path`, true sample times `t`
    [s], speeds `v` [m/s], arc lengths `s` [m], noisy positions `xy` (K, 2) [m]."""
    t, _, v, s = kinematics(*CURVE_KNOTS, v0=6.0, duration_s=14.0)
    rng = np.random.default_rng(7)
    xy = true_path(s) + rng.normal(0.0, NOISE_M, (len(s), 2))
    path = write_csv(tmp_path / "vehicle_tracks_000.csv",
                     car_rows("1", t, xy, true_heading(s), v))
    return SimpleNamespace(path=path, t=t, v=v, s=s, xy=xy)


def test_curved_track_controls_path_and_round_trip(curved):
    path, t, v, s, xy = curved.path, curved.t, curved.v, curved.s, curved.xy
    tracks = read_interaction_csv(path)
    assert list(tracks) == ["1"] and tracks["1"].source == "vehicle_tracks_000.csv"
    (fit,) = fit_track(tracks["1"], 100)
    true_u = np.diff(v) / DT  # the exact mean acceleration over each step
    err_u = fit.u - true_u
    inner = (t[:-1] >= 1.0) & (t[:-1] < t[-1] - 1.0)
    assert np.sqrt(np.mean(err_u[inner] ** 2)) < 0.3  # measured 0.17 m/s^2 (worst 0.20)
    for lo, hi in ((2.0, 4.5), (6.5, 8.5)):  # the constant +1.5 and -2.5 m/s^2 phases
        phase = (t[:-1] >= lo) & (t[:-1] < hi)
        assert np.sqrt(np.mean(err_u[phase] ** 2)) < 0.2  # measured 0.08-0.10 (20 seeds)
        assert abs(np.mean(fit.u[phase]) - np.mean(true_u[phase])) < 0.1
    assert np.sqrt(np.mean((fit.v - v) ** 2)) < 0.15  # measured 0.05 m/s

    # the reference path follows the true one; its 5 m extensions (10 vertices) the true
    # straight ends
    dense = true_path(np.linspace(-20.0, s[-1] + 20.0, 40001))
    gap = np.min(np.linalg.norm(fit.path[:, None] - dense[None], axis=-1), axis=1)
    assert np.max(gap[10:-10]) < 0.1  # measured 0.05 m (worst of 20 seeds 0.07)
    assert np.max(gap) < 0.5  # measured 0.14 m (worst 0.29) at the extensions' tips
    assert np.max(np.abs(np.linalg.norm(np.diff(fit.path, axis=0), axis=1) - 0.5)) < 0.01
    # local projections = Route.project's global ones on this path, recorded offsets ~ noise
    s_global, lat_global, _ = Route(fit.path).project(tracks["1"].xy)  # the file's (mm) values
    np.testing.assert_allclose(fit.s_obs, s_global, atol=1e-9)
    np.testing.assert_allclose(fit.lateral, lat_global, atol=1e-9)
    assert np.sqrt(np.mean(fit.lateral ** 2)) < 2 * NOISE_M
    assert fit.s_obs[0] > 4.0 and fit.s_obs[-1] < Route(fit.path).length_m - 4.0  # not clamped

    cut = SegmentCut(segment_steps=30, stride_steps=10, v_ref_mps=10.0)
    demos = interaction_demonstrations(tracks, cut)
    assert len(demos) == 12  # starts 0, 10, ..., 110 of 141 samples; never below 1 m/s
    for j, demo in enumerate(demos):
        i = 10 * j
        assert demo.agent == "track 1" and demo.source == "vehicle_tracks_000.csv"
        assert demo.t0_s == pytest.approx(0.1 * (i + 1))  # frame 1 is at 100 ms
        assert demo.dt_s == pytest.approx(DT) and demo.n_steps == 30
        assert np.all(np.isnan(demo.theta_true)) and math.isnan(demo.beta_true)
        assert demo.crosswalks == () and len(demo.others_length_m) == 0
        assert demo.prev_accel_mps2 == (0.0 if i == 0 else pytest.approx(fit.u[i - 1]))
        assert (demo.length_m, demo.width_m) == (4.5, 1.9)
        # round trip: controls integrated with the Demonstration's dynamics
        s_rep, v_rep, xy_rep, heading_rep = replay(demo)
        np.testing.assert_allclose(v_rep, v[i:i + 31], atol=0.3)
        rec = xy[i:i + 31]
        truth = true_path(s[i:i + 31])
        assert np.max(np.linalg.norm(xy_rep - truth, axis=1)) < 0.15  # measured 0.07 (0.12)
        assert np.max(np.linalg.norm(xy_rep - rec, axis=1)) < 0.25  # + the 5 cm noise
        assert np.sqrt(np.mean(np.sum((xy_rep - rec) ** 2, axis=1))) < 2 * NOISE_M
        heading_err = np.angle(np.exp(1j * (heading_rep - true_heading(s[i:i + 31]))))
        assert np.max(np.abs(heading_err)) < 0.08  # measured 0.03 rad (worst 0.05)
        # the path kept covers the segment and 30 m (or up to the track path's end) beyond it
        behind = min(fit.s[i], 30.0)
        assert behind - 1e-9 <= demo.s0_m <= behind + 0.5 + 1e-9
        ahead = min(Route(fit.path).length_m - fit.s[i + 30], 30.0)
        assert demo.route.length_m - s_rep[-1] >= ahead - 1e-6


def test_speed_comes_from_positions_not_recorded_velocities(curved, tmp_path):
    """The documented choice: v(t) from the smoothed arc length, so wrong (vx, vy) columns
    change nothing."""
    path = curved.path
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))[1:]
    for row in rows:
        row[6], row[7] = "0.0", "-3.0"
    other = write_csv(tmp_path / "wrong_velocities.csv", rows)
    (fit,) = fit_track(read_interaction_csv(path)["1"], 100)
    (fit_wrong,) = fit_track(read_interaction_csv(other)["1"], 100)
    np.testing.assert_array_equal(fit.u, fit_wrong.u)
    np.testing.assert_array_equal(fit.path, fit_wrong.path)


def test_default_v_ref_is_85th_percentile_speed(curved):
    demos = interaction_demonstrations(read_interaction_csv(curved.path))
    expected = np.percentile(curved.v[curved.v >= 1.0], 85)
    assert {d.v_ref_mps for d in demos} == {demos[0].v_ref_mps}
    assert demos[0].v_ref_mps == pytest.approx(expected, abs=0.1)


def scene(tmp_path, stem="000", n=61):
    """Ego car 1 along +x at 10 m/s; car 2 in the next lane (8 m/s, psi 0.05 rad, 4 x 1.8 m);
    car 3 leaves after frame 25; car 4 200 m away; pedestrian P1 crossing at x = 30 along +y
    at 1.4 m/s; pedestrian "2" (key P2) walking along -x. Returns (vehicle file, pedestrian
    file, {key: (K, 2) true positions})."""
    t = DT * np.arange(n)
    pos = {
        "1": np.stack([10.0 * t, np.zeros(n)], axis=1),
        "2": np.stack([5.0 + 8.0 * t, np.full(n, 3.5)], axis=1),
        "3": np.stack([-10.0 + 9.0 * t, np.full(n, -3.5)], axis=1)[:25],
        "4": np.stack([10.0 * t, np.full(n, 200.0)], axis=1),
        "P1": np.stack([np.full(n, 30.0), -5.0 + 1.4 * t], axis=1),
        "P2": np.stack([20.0 - 1.0 * t, np.full(n, -4.0)], axis=1),
    }
    rows = (car_rows("1", t, pos["1"], np.zeros(n), np.full(n, 10.0))
            + car_rows("2", t, pos["2"], np.full(n, 0.05), np.full(n, 8.0), length=4.0,
                       width=1.8)
            + car_rows("3", t[:25], pos["3"], np.zeros(25), np.full(25, 9.0))
            + car_rows("4", t, pos["4"], np.zeros(n), np.full(n, 10.0)))
    vehicles = write_csv(tmp_path / f"vehicle_tracks_{stem}.csv", rows)
    peds = write_csv(tmp_path / f"pedestrian_tracks_{stem}.csv",
                     ped_rows("P1", pos["P1"], np.tile([0.0, 1.4], (n, 1)))
                     + ped_rows("2", pos["P2"], np.tile([-1.0, 0.0], (n, 1))),
                     columns=BASE_COLUMNS)  # INTERACTION's pedestrian files have 8 columns
    return vehicles, peds, pos


def test_others_positions_footprints_and_presence(tmp_path):
    vehicles, peds, pos = scene(tmp_path)
    tracks = read_interaction_csv([vehicles, peds])
    assert sorted(tracks) == ["1", "2", "3", "4", "P1", "P2"]
    assert tracks["P2"].is_pedestrian and not tracks["2"].is_pedestrian
    assert tracks["P1"].source == "pedestrian_tracks_000.csv"
    cut = SegmentCut(segment_steps=10, stride_steps=10, v_ref_mps=10.0)
    demos = interaction_demonstrations(tracks, cut)
    ego = [d for d in demos if d.agent == "track 1"]
    assert [d.t0_s for d in ego] == pytest.approx([0.1, 1.1, 2.1, 3.1, 4.1, 5.1])
    expected_heading = {"2": 0.05, "3": 0.0, "P1": 0.5 * math.pi, "P2": math.pi}
    footprint = {"2": (4.0, 1.8), "3": (4.5, 1.9), "P1": (PEDESTRIAN_DIAMETER_M,) * 2,
                 "P2": (PEDESTRIAN_DIAMETER_M,) * 2}
    for j, demo in enumerate(ego):
        i = 10 * j
        # car 3 is recorded at samples 0..24: present for the whole segments 0-10 and 10-20,
        # leaves within 20-30; car 4 is 200 m away
        want = {"2", "P1", "P2"} | ({"3"} if i + 10 <= 24 else set())
        found = set()
        for m in range(len(demo.others_length_m)):
            key = next(k for k in want
                       if np.allclose(demo.others_xy[m], pos[k][i + 1:i + 11], atol=2e-3))
            found.add(key)
            np.testing.assert_allclose(demo.others_heading[m], expected_heading[key], atol=1e-3)
            assert (demo.others_length_m[m], demo.others_width_m[m]) == footprint[key]
            assert demo.others_is_pedestrian[m] == key.startswith("P")
        assert found == want and len(demo.others_length_m) == len(want)
        _, v_rep, xy_rep, _ = replay(demo)
        np.testing.assert_allclose(xy_rep, pos["1"][i:i + 11], atol=0.02)
        np.testing.assert_allclose(v_rep, 10.0, atol=0.02)
    # a smaller radius leaves out what is farther at the segment start
    cut = SegmentCut(segment_steps=10, stride_steps=10, v_ref_mps=10.0, radius_m=8.0)
    near = interaction_demonstrations(tracks, cut)
    first = next(d for d in near if d.agent == "track 1")  # ego at (0, 0): car 2 at (5, 3.5)
    assert len(first.others_length_m) == 1 and first.others_length_m[0] == 4.0


def test_segments_with_a_stop_are_skipped(tmp_path):
    # 8 m/s, brake at -2 m/s^2 to a stop at t = 5.25 s, stand until 8 s (with the position
    # noise), accelerate at +2 m/s^2 back to 8 m/s
    knots = ((0, 1, 1.25, 5.0, 5.25, 8.0, 8.25, 12.0, 12.25, 16),
             (0, 0, -2, -2, 0, 0, 2, 2, 0, 0))
    t, _, v, s = kinematics(*knots, v0=8.0, duration_s=16.0)
    assert np.max(np.abs(v[53:80])) < 1e-6  # standing
    v = np.maximum(v, 0.0)
    rng = np.random.default_rng(3)
    xy = np.stack([s, np.zeros_like(s)], axis=1) + rng.normal(0.0, NOISE_M, (len(s), 2))
    path = write_csv(tmp_path / "stop.csv", car_rows("9", t, xy, np.zeros(len(t)), v))
    tracks = read_interaction_csv(path)
    (fit,) = fit_track(tracks["9"], 100)  # the path does not fold where the car stands
    step = np.diff(fit.path, axis=0)
    assert np.max(np.abs(np.arctan2(step[:, 1], step[:, 0]))) < 0.1  # measured 0.02-0.05 rad
    assert np.max(np.abs(fit.path[10:-10, 1])) < 0.1  # without the 5 m extensions
    cut = SegmentCut(segment_steps=20, stride_steps=5, v_ref_mps=8.0)
    demos = interaction_demonstrations(tracks, cut)
    starts = np.array([round(d.t0_s / DT) - 1 for d in demos])
    window_min = np.array([v[i:i + 21].min() for i in range(len(v) - 20)])
    assert not np.any(window_min[starts] < 0.5)  # no kept segment comes near the stop
    candidates = np.arange(0, len(window_min), 5)
    assert set(candidates[window_min[candidates] >= 1.5]) <= set(starts)  # the moving ones
    assert np.any(starts < 20) and np.any(starts > 100)  # before and after the stop
    for demo, i in zip(demos, starts):  # round trip after the noisy standstill, too
        _, v_rep, xy_rep, _ = replay(demo)
        assert v_rep.min() >= 1.0
        assert np.max(np.abs(xy_rep[:, 0] - s[i:i + 21])) < 0.15
        assert np.max(np.abs(xy_rep[:, 1])) < 0.1


def test_validation_errors(tmp_path):
    t = DT * np.arange(40)
    good = car_rows("1", t, np.stack([10 * t, 0 * t], axis=1), 0 * t, 10 + 0 * t)

    no_vy = write_csv(tmp_path / "no_vy.csv", [r[:7] + r[8:] for r in good],
                      [c for c in CSV_COLUMNS if c != "vy"])
    with pytest.raises(ValueError, match=r"no_vy\.csv: missing column.*'vy'"):
        read_interaction_csv(no_vy)
    no_psi = write_csv(tmp_path / "no_psi.csv", [r[:8] for r in good], BASE_COLUMNS)
    with pytest.raises(ValueError, match=r"no_psi\.csv: missing column 'psi_rad'.*vehicle"):
        read_interaction_csv(no_psi)

    rows = [list(r) for r in good]
    rows[5][1], rows[5][2] = rows[4][1], rows[4][2]  # line 7 repeats frame 5 of line 6
    dup = write_csv(tmp_path / "dup.csv", rows)
    with pytest.raises(ValueError, match=r"dup\.csv lines 6 and 7: duplicate .*\(1, 5\).*"
                                         r"frame_id"):
        read_interaction_csv(dup)

    rows = [list(r) for r in good]
    rows[9][4] = "abc"
    bad = write_csv(tmp_path / "bad.csv", rows)
    with pytest.raises(ValueError, match=r"bad\.csv line 11 \(track 1\): column 'x' must be a "
                                         r"finite number, got 'abc'"):
        read_interaction_csv(bad)
    rows[9][4], rows[12][8] = "1.0", ""
    empty_psi = write_csv(tmp_path / "empty_psi.csv", rows)
    with pytest.raises(ValueError, match=r"line 14 \(track 1\): column 'psi_rad'"):
        read_interaction_csv(empty_psi)

    rows = [list(r) for r in good]
    rows[20][2] = 1500  # frame 21 stamped before frame 20 (2000 ms)
    back = write_csv(tmp_path / "back.csv", rows)
    with pytest.raises(ValueError, match=r"back\.csv line 22 \(track 1\): column 'timestamp_ms' "
                                         r"not increasing"):
        read_interaction_csv(back)

    twice = write_csv(tmp_path / "twice.csv", good)
    with pytest.raises(ValueError, match=r"track id 1 appears in both no_psi_ok\.csv and "
                                         r"twice\.csv"):
        read_interaction_csv([write_csv(tmp_path / "no_psi_ok.csv", good), twice])

    rows = [list(r) for r in good]
    for r in rows:
        r[2] = r[1] * 50  # 20 Hz
    fast = write_csv(tmp_path / "fast.csv", rows)
    with pytest.raises(ValueError, match=r"fast\.csv: samples are 50 ms apart, expected 100 ms"):
        interaction_demonstrations(read_interaction_csv(fast))
    cut = SegmentCut(expected_dt_s=None, v_ref_mps=10.0)
    demos = interaction_demonstrations(read_interaction_csv(fast), cut)
    assert demos[0].dt_s == pytest.approx(0.05)


def test_save_load_round_trip(tmp_path):
    vehicles, peds, _ = scene(tmp_path)
    cut = SegmentCut(segment_steps=10, stride_steps=10, v_ref_mps=10.0)
    demos = interaction_demonstrations(read_interaction_csv([vehicles, peds]), cut)
    assert len({len(d.others_length_m) for d in demos}) > 1  # padding is exercised
    loaded = load_demonstrations(save_demonstrations(tmp_path / "demos.npz", demos))
    assert len(loaded) == len(demos)
    for a, b in zip(demos, loaded):
        for name in ("controls_mps2", "path_xy", "others_xy", "others_heading",
                     "others_length_m", "others_width_m", "others_is_pedestrian", "theta_true"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        for name in ("dt_s", "s0_m", "v0_mps", "prev_accel_mps2", "v_ref_mps", "length_m",
                     "width_m", "agent", "source", "t0_s", "crosswalks"):
            assert getattr(a, name) == getattr(b, name), name
        np.testing.assert_array_equal(replay(a)[2], replay(b)[2])


def test_load_interaction_groups_recordings(tmp_path):
    scene(tmp_path, "000")
    scene(tmp_path, "001")  # the same track ids: must not be merged with recording 000
    cut = SegmentCut(segment_steps=10, stride_steps=10, v_ref_mps=10.0)
    demos = load_interaction([tmp_path], cut)
    sources = [d.source for d in demos]
    assert set(sources) == {"vehicle_tracks_000.csv", "vehicle_tracks_001.csv"}
    assert sources.count("vehicle_tracks_000.csv") == sources.count("vehicle_tracks_001.csv")
    assert any(d.others_is_pedestrian.any() for d in demos if d.source.endswith("001.csv"))
    with pytest.raises(ValueError, match="appears in both"):
        read_interaction_csv(sorted(tmp_path.glob("vehicle_tracks_*.csv")))


def test_gaps_split_tracks_and_pedestrian_headings(tmp_path):
    t = DT * np.arange(100)
    rows = car_rows("1", t, np.stack([10 * t, 0 * t], axis=1), 0 * t, 10 + 0 * t)
    del rows[40:50]  # frames 41-50 missing: two runs, frames 1-40 and 51-100
    # a pedestrian standing, walking north, standing, walking west
    vxy = np.array([[0.0, 0.0]] * 3 + [[0.0, 1.0]] * 3 + [[0.0, 0.05]] * 3 + [[-1.0, 0.0]] * 3)
    peds = ped_rows("P1", np.cumsum(vxy, axis=0) * DT, vxy)
    tracks = read_interaction_csv([write_csv(tmp_path / "gap.csv", rows),
                                   write_csv(tmp_path / "peds.csv", peds, BASE_COLUMNS)])
    np.testing.assert_allclose(tracks["P1"].heading_rad(), [0.5 * math.pi] * 9 + [math.pi] * 3)
    assert len(fit_track(tracks["1"], 100)) == 2
    cut = SegmentCut(segment_steps=10, stride_steps=5, v_ref_mps=10.0)
    demos = interaction_demonstrations(tracks, cut)
    first_frames = [round(d.t0_s / DT) for d in demos]
    assert first_frames == [1, 6, 11, 16, 21, 26, 51, 56, 61, 66, 71, 76, 81, 86]
    assert [d.prev_accel_mps2 for d in demos][6] == 0.0  # first step of the second run
    # a recording without any moving car gives no demonstrations (and needs no v_ref)
    assert interaction_demonstrations(read_interaction_csv(tmp_path / "peds.csv")) == []


def test_smoother_keeps_constant_acceleration_up_to_the_ends():
    """The jerk penalty's null space is constant acceleration: noise-free, it is recovered
    exactly at every step (a cubic smoothing spline would pull the end accelerations to 0)."""
    t = DT * np.arange(60)
    s_obs = 3.0 + 7.0 * t - 0.5 * 2.5 * t ** 2
    s, v = smooth_arc_length(s_obs, DT)
    np.testing.assert_allclose(np.diff(v) / DT, -2.5, atol=1e-6)
    np.testing.assert_allclose(s, s_obs, atol=1e-8)
    np.testing.assert_allclose(v, 7.0 - 2.5 * t, atol=1e-7)


def test_tracking_glitch_drops_its_segments(curved, tmp_path):
    with open(curved.path, newline="") as fh:
        rows = list(csv.reader(fh))[1:]
    rows[70][5] = f"{float(rows[70][5]) + 3.0:.3f}"  # sample 70 jumps 3 m sideways
    glitch = write_csv(tmp_path / "glitch.csv", rows)
    cut = SegmentCut(v_ref_mps=10.0)
    with pytest.warns(UserWarning, match=r"segment\(s\) dropped: replay misses"):
        demos = interaction_demonstrations(read_interaction_csv(glitch), cut)
    starts = [round(d.t0_s / DT) - 1 for d in demos]
    assert not any(i <= 70 <= i + 30 for i in starts)
    assert starts == [0, 10, 20, 30, 80, 90, 100, 110]
