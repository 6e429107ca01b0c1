"""Demonstrations for inverse optimal control from real-world tracks in the CSV schema of the
INTERACTION dataset (Zhan et al. 2019, interaction-dataset.com).

Input: one recording = the track files of one scene and time span, e.g. ``vehicle_tracks_000.csv``
and ``pedestrian_tracks_000.csv``, with the columns

    track_id, frame_id, timestamp_ms, agent_type, x, y, vx, vy, psi_rad, length, width

(10 Hz, positions of the footprint centres [m], velocities [m/s], heading [rad], footprint [m]).
Pedestrian files ("pedestrian/bicycle", ids like "P1") may leave out or leave empty psi_rad,
length and width. Output: `marl_social.demonstrations.Demonstration` segments.

Pipeline per vehicle track (per contiguous run of frames, see `fit_track`):

1. Reference path (`fit_reference_path`): x(t), y(t) smoothed by penalized least squares
   (`whittaker_smooth`, the discrete cubic smoothing spline) with the penalty chosen as a
   low-pass filter of gain 1/2 at PATH_CUTOFF_HZ = 1 Hz (a lane change takes ~4 s, a 30 m
   curve at 15 m/s ~3 s: the geometry passes, sample-to-sample position noise does not).
   Where the smoothed curve moves slower than PATH_MIN_SPEED_MPS = 0.5 m/s it is left out
   (standing, the smoothed noise wanders on the spot and would fold the path). The curve is
   resampled by arc length, smoothed once more in space (gain 1/2 at a PATH_WAVELENGTH_M = 5 m
   wavelength: kinks left by low-speed noise go, curves of road radii stay), resampled every
   PATH_SPACING_M = 0.5 m and extended by PATH_EXTENSION_M = 5 m beyond both ends so that no
   projection is clamped.
2. Arc length s_obs(t): each recorded position projected onto that path (locally, near the
   smoothed curve's own arc length at that time, so a path that comes back near itself, e.g.
   in a roundabout, cannot capture a projection).
3. Speed along the path from the smoothed s(t) (not from vx, vy): `smooth_arc_length` fits
   (s_k, v_k) that obey the Demonstration's own dynamics exactly (s by the trapezoid rule),
   closest to s_obs with a penalty on jerk (gain 1/2 at SPEED_CUTOFF_HZ = 0.5 Hz). So the
   controls u_k = (v_{k+1} - v_k)/dt replay the fitted s_k to rounding error, constant
   accelerations are reproduced without bias up to the ends of a track (a jerk penalty, unlike
   a cubic smoothing spline's natural end conditions, does not pull the end accelerations to
   zero), and the recorded (vx, vy) - themselves filter outputs of the dataset's tracker, not
   measurements - are used only for the pedestrians' headings.
4. Segments of T controls every `stride_steps`, dropped where the speed falls below
   min_speed_mps (see `interaction_demonstrations`) or where the replay misses the recorded
   positions by more than max_roundtrip_error_m.

Accuracy (tests/test_interaction.py: a car on a 30 m radius curve, +1.5 then -2.5 m/s^2 with
1 s jerk-limited transitions, 5 cm Gaussian position noise; mean / worst of 20 noise draws):
controls RMS error 0.17 / 0.20 m/s^2 (0.08-0.10 / 0.16 within the constant phases, up to 0.7
at the transitions), speed RMS 0.05 / 0.06 m/s, path within 0.05 / 0.07 m of the true path
(extension tips 0.14 / 0.28 m), replayed positions within 0.07 / 0.11 m of the true and
0.15 / 0.18 m of the noisy recorded positions.
"""

from __future__ import annotations

import csv
import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from numpy.lib.stride_tricks import sliding_window_view
from scipy.interpolate import CubicSpline
from scipy.linalg import solveh_banded
from scipy.sparse.linalg import spsolve

from marl_social.data.demonstrations import Demonstration
from marl_social.sim.road_map import Route

CSV_COLUMNS = ("track_id", "frame_id", "timestamp_ms", "agent_type", "x", "y", "vx", "vy",
               "psi_rad", "length", "width")
BASE_COLUMNS = CSV_COLUMNS[:8]  # required in every file
VEHICLE_COLUMNS = CSV_COLUMNS[8:]  # required (non-empty) for rows that are not pedestrians
PEDESTRIAN_TYPES = frozenset({"pedestrian/bicycle", "pedestrian", "bicycle"})
PEDESTRIAN_DIAMETER_M = 0.6  # footprint of pedestrians and cyclists (length = width) [m]
PATH_CUTOFF_HZ = 1.0  # x(t), y(t) smoothing: gain 1/2 at this frequency [Hz]
SPEED_CUTOFF_HZ = 0.5  # s(t) smoothing: gain 1/2 at this frequency [Hz]
PATH_SPACING_M = 0.5  # vertex spacing of the reference path [m]
PATH_EXTENSION_M = 5.0  # straight extension beyond both ends of a track's path [m]
END_CHORD_M = 2.0  # the extensions follow the chord over the path's first / last 2 m
PATH_MIN_SPEED_MPS = 0.5  # the path skips where the smoothed x(t), y(t) move slower [m/s]
PATH_WAVELENGTH_M = 5.0  # second, spatial smoothing of the path: gain 1/2 at this wavelength
PATH_MARGIN_M = 30.0  # path kept in a demonstration beyond the segment's ends [m]
PROJECTION_WINDOW_M = 5.0  # projections search this far from the smoothed curve's own s [m]
V_REF_PERCENTILE = 85.0  # default v_ref: this percentile of the moving vehicles' speeds
MAX_ROUNDTRIP_ERROR_M = 0.5  # segments whose replay misses the record by more are dropped [m]
_SUBSAMPLES = 10  # dense evaluation of the path splines per recorded step
_MIN_HEADING_SPEED_MPS = 0.2  # below this a pedestrian keeps its last direction of motion
_RECORDING_NAME = re.compile(r"^(?:vehicle|pedestrian)_tracks_(\d+)\.csv$")


@dataclass(frozen=True)
class Track:
    """One agent's track, sorted by frame (K samples).

    Attributes:
        track_id: key in the recording: the file's id; pedestrian ids get a leading "P" if they
            have none (as in INTERACTION's "P1"), so they stay distinct from vehicle ids.
        agent_type: the file's agent_type ("car", "pedestrian/bicycle", ...).
        source: file name the track comes from.
        frame_id: (K,) int64; timestamp_ms: (K,) int64, strictly increasing [ms].
        xy: (K, 2) centre positions [m]; vxy: (K, 2) velocities [m/s].
        psi_rad: (K,) heading [rad] (NaN for pedestrians).
        length_m, width_m: footprint [m] (median over the track; pedestrians:
            PEDESTRIAN_DIAMETER_M).
    """

    track_id: str
    agent_type: str
    source: str
    frame_id: np.ndarray
    timestamp_ms: np.ndarray
    xy: np.ndarray
    vxy: np.ndarray
    psi_rad: np.ndarray
    length_m: float
    width_m: float

    @property
    def is_pedestrian(self) -> bool:
        return self.agent_type in PEDESTRIAN_TYPES

    @property
    def t_s(self) -> np.ndarray:
        """(K,) sample times [s]."""
        return self.timestamp_ms * 1e-3

    def heading_rad(self) -> np.ndarray:
        """(K,) heading [rad]: psi_rad for vehicles; for pedestrians the direction of motion
        atan2(vy, vx), held from the last sample moving faster than 0.2 m/s (the first such
        direction before it; 0 if the pedestrian never moves).
        """
        if not self.is_pedestrian:
            return self.psi_rad
        speed = np.hypot(self.vxy[:, 0], self.vxy[:, 1])
        moving = speed >= _MIN_HEADING_SPEED_MPS
        if not np.any(moving):
            return np.zeros(len(speed))
        idx = np.where(moving, np.arange(len(speed)), -1)
        idx = np.maximum.accumulate(idx)
        idx[idx < 0] = np.argmax(moving)
        return np.arctan2(self.vxy[idx, 1], self.vxy[idx, 0])


# --------------------------------------------------------------------------------------------
# reading


def _parse_numeric(values: np.ndarray, lines: np.ndarray, column: str, path: Path,
                   track_ids: np.ndarray, integral: bool = False) -> np.ndarray:
    """Column strings (R,) -> float64 (R,); ValueError naming file, line, track and column."""
    try:
        out = values.astype(np.float64)
        bad = ~np.isfinite(out)
        if integral:
            bad |= out != np.round(out)
    except ValueError:  # error path only: find the offending row
        out = np.full(len(values), np.nan)
        for i, text in enumerate(values.tolist()):
            try:
                out[i] = float(text)
            except ValueError:
                break
        bad = ~np.isfinite(out)
    if np.any(bad):
        i = int(np.argmax(bad))
        kind = "an integer" if integral else "a finite number"
        raise ValueError(f"{path.name} line {lines[i]} (track {track_ids[i]}): column "
                         f"{column!r} must be {kind}, got {str(values[i])!r}")
    return out


def _read_file(path: Path) -> dict[str, Track]:
    """One CSV file -> tracks (see read_interaction_csv)."""
    if not path.is_file():
        raise FileNotFoundError(f"INTERACTION track file {path} does not exist")
    with open(path, newline="", encoding="utf-8-sig") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None:
            raise ValueError(f"{path.name}: empty file, expected a header with the columns "
                             f"{', '.join(CSV_COLUMNS)}")
        header = [h.strip() for h in header]
        missing = [c for c in BASE_COLUMNS if c not in header]
        if missing:
            raise ValueError(f"{path.name}: missing column(s) {missing} (header: {header})")
        rows, lines = [], []
        for row in reader:
            if not row or all(not f.strip() for f in row):
                continue
            if len(row) != len(header):
                raise ValueError(f"{path.name} line {reader.line_num}: {len(row)} fields, the "
                                 f"header has {len(header)}")
            rows.append(row)
            lines.append(reader.line_num)
    if not rows:
        raise ValueError(f"{path.name}: no data rows")
    table = np.char.strip(np.array(rows, dtype=str))
    lines = np.array(lines)
    col = {name: table[:, header.index(name)] for name in header}
    ids, types = col["track_id"], col["agent_type"]
    ped = np.isin(types, list(PEDESTRIAN_TYPES))
    if np.any(ids == ""):
        i = int(np.argmax(ids == ""))
        raise ValueError(f"{path.name} line {lines[i]}: column 'track_id' is empty")
    ids = np.where(ped & ~np.char.startswith(ids, "P"), np.char.add("P", ids), ids)
    num = {name: _parse_numeric(col[name], lines, name, path, ids,
                                integral=name in ("frame_id", "timestamp_ms"))
           for name in ("frame_id", "timestamp_ms", "x", "y", "vx", "vy")}
    for name in VEHICLE_COLUMNS:
        values = np.full(len(rows), np.nan)
        if np.any(~ped):
            if name not in header:
                raise ValueError(f"{path.name}: missing column {name!r} (needed for the "
                                 f"vehicle rows, e.g. line {lines[np.argmax(~ped)]})")
            values[~ped] = _parse_numeric(col[name][~ped], lines[~ped], name, path, ids[~ped])
        num[name] = values
    for name in ("length", "width"):
        bad = ~ped & ~(num[name] > 0)
        if np.any(bad):
            i = int(np.argmax(bad))
            raise ValueError(f"{path.name} line {lines[i]} (track {ids[i]}): column {name!r} "
                             f"must be > 0, got {str(col[name][i])!r}")
    frame, stamp = num["frame_id"].astype(np.int64), num["timestamp_ms"].astype(np.int64)

    uniq, first_row, inv = np.unique(ids, return_index=True, return_inverse=True)
    order = np.lexsort((frame, inv))
    same = inv[order][1:] == inv[order][:-1]
    dup = same & (frame[order][1:] == frame[order][:-1])
    if np.any(dup):
        j = int(np.argmax(dup))
        a, b = sorted((lines[order][j], lines[order][j + 1]))
        raise ValueError(f"{path.name} lines {a} and {b}: duplicate (track_id, frame_id) = "
                         f"({ids[order][j]}, {frame[order][j]}) (column 'frame_id')")
    back = same & (np.diff(stamp[order]) <= 0)
    if np.any(back):
        j = int(np.argmax(back))
        raise ValueError(f"{path.name} line {lines[order][j + 1]} (track {ids[order][j]}): "
                         f"column 'timestamp_ms' not increasing with frame_id "
                         f"({stamp[order][j]} at frame {frame[order][j]}, then "
                         f"{stamp[order][j + 1]} at frame {frame[order][j + 1]})")

    bounds = np.searchsorted(inv[order], np.arange(len(uniq) + 1))
    tracks = {}
    for n in np.argsort(first_row).tolist():  # one iteration per track, in file order
        key = str(uniq[n])
        rows_n = order[bounds[n]:bounds[n + 1]]
        kinds = np.unique(types[rows_n])
        if len(kinds) != 1:
            raise ValueError(f"{path.name}: track {key} has several agent_type values "
                             f"{kinds.tolist()} (column 'agent_type')")
        is_ped = bool(ped[rows_n[0]])
        tracks[key] = Track(
            track_id=key, agent_type=str(kinds[0]), source=path.name,
            frame_id=frame[rows_n], timestamp_ms=stamp[rows_n],
            xy=np.stack([num["x"][rows_n], num["y"][rows_n]], axis=1),
            vxy=np.stack([num["vx"][rows_n], num["vy"][rows_n]], axis=1),
            psi_rad=num["psi_rad"][rows_n],
            length_m=PEDESTRIAN_DIAMETER_M if is_ped else float(np.median(num["length"][rows_n])),
            width_m=PEDESTRIAN_DIAMETER_M if is_ped else float(np.median(num["width"][rows_n])),
        )
    return tracks


def read_interaction_csv(path_or_paths) -> dict[str, Track]:
    """Read the track files of ONE recording (e.g. its vehicle and its pedestrian file) into
    tracks keyed by track id.

    Args:
        path_or_paths: a path or a sequence of paths to CSV files in the INTERACTION schema
            (CSV_COLUMNS; psi_rad, length, width only needed for non-pedestrian rows).

    Returns:
        {track_id: Track}, in the order of first appearance. Pedestrian ids without a leading "P"
        get one, so pedestrian and vehicle ids stay distinct.

    Raises:
        FileNotFoundError for a missing file; ValueError naming the file, line / track and column
        for a missing column, a non-numeric or non-finite value, a non-integral frame_id /
        timestamp_ms, a duplicate (track_id, frame_id), timestamps not increasing with the frame
        within a track, a non-positive length / width, and for the same track id in two files
        (files of different recordings: read them separately, see `load_interaction`).
    """
    paths = [path_or_paths] if isinstance(path_or_paths, (str, Path)) else list(path_or_paths)
    if not paths:
        raise ValueError("read_interaction_csv: no files given")
    tracks: dict[str, Track] = {}
    for path in map(Path, paths):
        for key, track in _read_file(path).items():
            if key in tracks:
                raise ValueError(f"track id {key} appears in both {tracks[key].source} and "
                                 f"{path.name}: files of different recordings must be read "
                                 f"separately")
            tracks[key] = track
    return tracks


# --------------------------------------------------------------------------------------------
# kinematics of one track


def whittaker_smooth(y, step: float, cutoff: float) -> np.ndarray:
    """Whittaker-Henderson smoother, the discrete cubic smoothing spline of equally spaced
    samples: f = argmin sum_k |y_k - f_k|^2 + lam sum_k |f_{k+1} - 2 f_k + f_{k-1}|^2, a banded
    solve, O(n). As a filter its gain is 1 / (1 + lam (2 - 2 cos(w h))^2); lam is chosen for
    gain 1/2 at the cutoff (scipy's make_smoothing_spline is the continuous equivalent, but
    costs ~30 us per sample and made the whole pipeline 3.4 times slower).

    Args:
        y: (n, d) samples every `step` (any unit: s or m), n >= 3.
        cutoff: frequency of gain 1/2 in cycles per unit of step (Hz for seconds).

    Returns:
        (n, d) smoothed samples.
    """
    y = np.asarray(y, dtype=np.float64)
    n = len(y)
    lam = 1.0 / (2.0 - 2.0 * math.cos(min(2.0 * math.pi * cutoff * step, math.pi))) ** 2
    second = sp.diags([np.ones(n - 2), -2.0 * np.ones(n - 2), np.ones(n - 2)], [0, 1, 2],
                      shape=(n - 2, n))
    gram = (second.T @ second).tocsr()
    ab = np.zeros((3, n))
    ab[2] = 1.0 + lam * gram.diagonal(0)
    ab[1, 1:] = lam * gram.diagonal(1)
    ab[0, 2:] = lam * gram.diagonal(2)
    return solveh_banded(ab, y)


def _resample(points: np.ndarray, spacing_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Polyline points (N, 2) [m] -> (n+1, 2) points equally spaced by ~spacing_m along it and
    the arc length of each input point [m].
    """
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    n = max(round(float(cum[-1]) / spacing_m), 1)
    grid = np.linspace(0.0, cum[-1], n + 1)
    return np.stack([np.interp(grid, cum, points[:, 0]), np.interp(grid, cum, points[:, 1])],
                    axis=1), cum


def fit_reference_path(t_s, xy, cutoff_hz: float = PATH_CUTOFF_HZ,
                       spacing_m: float = PATH_SPACING_M,
                       extension_m: float = PATH_EXTENSION_M):
    """Smooth reference path of a track.

    x(t), y(t) are low-passed (`whittaker_smooth`, gain 1/2 at cutoff_hz), interpolated by a
    cubic spline at 10 points per step; where that curve moves slower than PATH_MIN_SPEED_MPS
    it is left out (standing, the smoothed noise wanders on the spot and would fold the path;
    the path joins the points before and after by a chord). The curve is resampled every
    spacing_m, smoothed in space (x(sigma), y(sigma), gain 1/2 at PATH_WAVELENGTH_M: removes the
    kinks low-speed noise leaves; a curve of radius R moves by ~R (2 pi R / 5 m)^-4, 2 mm at
    R = 6 m), resampled again and extended straight beyond both ends.

    Args:
        t_s: (K,) sample times [s], equally spaced, K >= 5.
        xy: (K, 2) recorded positions [m].
        cutoff_hz: smoothing of x(t), y(t), gain 1/2 at this frequency [Hz].
        spacing_m: vertex spacing of the path [m]; extension_m: straight extension beyond both
            ends along the chords over their last END_CHORD_M [m].

    Returns:
        path: (P, 2) polyline [m] in travel order, or None if the smoothed curve is shorter than
        3.5 spacing_m (the agent hardly moves); sigma: (K,) arc length along that path of the
        smoothed curve at each sample time [m] (where the projection search starts).
    """
    t = np.asarray(t_s, dtype=np.float64)
    rel = t - t[0]
    dt = float(rel[-1] / (len(t) - 1))
    curve = CubicSpline(rel, whittaker_smooth(xy, dt, cutoff_hz), axis=0)
    dense_t = np.linspace(0.0, rel[-1], (len(t) - 1) * _SUBSAMPLES + 1)
    speed = np.linalg.norm(curve(dense_t, 1), axis=1)
    keep = np.flatnonzero(speed >= PATH_MIN_SPEED_MPS)
    if len(keep) < 2:
        return None, None
    core, cum = _resample(curve(dense_t[keep]), spacing_m)
    if len(core) < 5:
        return None, None
    # arc length of every sample: that of the last kept dense point at or before it
    last = np.maximum.accumulate(np.where(speed >= PATH_MIN_SPEED_MPS,
                                          np.arange(len(speed)), -1))
    sigma = cum[np.clip(np.searchsorted(keep, last[::_SUBSAMPLES]), 0, len(keep) - 1)]
    grid = np.linspace(0.0, cum[-1], len(core))
    smooth = whittaker_smooth(core, grid[1], 1.0 / PATH_WAVELENGTH_M)
    core, cum2 = _resample(smooth, spacing_m)
    sigma = np.interp(sigma, grid, cum2)
    n = len(core) - 1
    n_ext = math.ceil(extension_m / spacing_m)
    step = np.arange(n_ext, 0, -1)[:, None] * spacing_m
    # end directions: chords over the last END_CHORD_M of the curve (a smoothing spline's end
    # segment alone is its noisiest part)
    m = min(max(round(END_CHORD_M / spacing_m), 1), n)
    d0 = (core[m] - core[0]) / np.linalg.norm(core[m] - core[0])
    d1 = (core[-1] - core[-1 - m]) / np.linalg.norm(core[-1] - core[-1 - m])
    path = np.concatenate([core[0] - step * d0, core, core[-1] + step[::-1] * d1])
    return path, sigma + n_ext * spacing_m


def project_local(path, xy, s_guess, window_m: float = PROJECTION_WINDOW_M):
    """Project points onto a polyline, each searching only near its own guess.

    Args:
        path: (P, 2) polyline [m]; xy: (K, 2) points [m]; s_guess: (K,) arc lengths [m] near
        which each point's closest point lies; window_m: half-width of the search [m].

    Returns:
        s: (K,) arc length of the closest point within the window [m]; lateral: (K,) signed
        offset, left of travel positive [m]. Same convention as road_map.Route.project.
    """
    route = Route(path, "reference path")
    n_seg = len(route._seg_len)
    w = math.ceil(window_m / float(np.min(route._seg_len))) + 1
    w = min(w, n_seg)
    k0 = np.clip(np.searchsorted(route._cum_s, s_guess, side="right") - 1, 0, n_seg - 1)
    cand = np.clip(k0[:, None] + np.arange(-w, w + 1), 0, n_seg - 1)  # (K, 2w+1)
    rel = np.asarray(xy, dtype=np.float64)[:, None, :] - route._seg_start[cand]
    direction = route._seg_dir[cand]
    along = np.clip(np.sum(rel * direction, axis=-1), 0.0, route._seg_len[cand])
    d2 = np.sum((rel - along[..., None] * direction) ** 2, axis=-1)
    j = np.argmin(d2, axis=1)[:, None]
    k = np.take_along_axis(cand, j, axis=1)[:, 0]
    a = np.take_along_axis(along, j, axis=1)[:, 0]
    r = np.take_along_axis(rel, j[..., None], axis=1)[:, 0]
    lateral = route._seg_dir[k, 0] * r[:, 1] - route._seg_dir[k, 1] * r[:, 0]
    return route._cum_s[k] + a, lateral


def smooth_arc_length(s_obs, dt_s: float, cutoff_hz: float = SPEED_CUTOFF_HZ):
    """Fit arc length and speed that follow the Demonstration's dynamics exactly.

    Solves  min_{s, v}  sum_k (s_k - s_obs_k)^2 + lam sum_k j_k^2,
            j_k = (v_{k+2} - 2 v_{k+1} + v_k) / dt^2  (jerk),
            s.t. s_{k+1} = s_k + dt (v_k + v_{k+1}) / 2  (trapezoid rule),
    a sparse equality-constrained least-squares problem (KKT system, O(K)). As a filter on
    s_obs it has the transfer function 1 / (1 + lam w^6); lam = (2 pi cutoff_hz)^-6 gives gain
    1/2 at cutoff_hz. Polynomials up to degree 5 pass without bias in the interior, up to
    degree 2 (constant acceleration) up to the ends.

    Args:
        s_obs: (K,) arc lengths at equally spaced times [m], K >= 3; dt_s: step [s].

    Returns:
        s: (K,) [m], v: (K,) [m/s]; u = diff(v) / dt are the controls.
    """
    y = np.asarray(s_obs, dtype=np.float64)
    k = len(y)
    if k < 3:
        raise ValueError(f"smooth_arc_length: need at least 3 samples, got {k}")
    lam = (2.0 * math.pi * cutoff_hz) ** -6
    second = sp.diags([np.ones(k - 2), -2.0 * np.ones(k - 2), np.ones(k - 2)], [0, 1, 2],
                      shape=(k - 2, k)) / dt_s ** 2
    hess = sp.block_diag([sp.identity(k), lam * (second.T @ second)])
    ds = sp.diags([-np.ones(k - 1), np.ones(k - 1)], [0, 1], shape=(k - 1, k))
    avg = sp.diags([np.ones(k - 1), np.ones(k - 1)], [0, 1], shape=(k - 1, k)) * (0.5 * dt_s)
    cons = sp.hstack([ds, -avg])
    kkt = sp.bmat([[hess, cons.T], [cons, None]], format="csc")
    rhs = np.concatenate([y, np.zeros(k), np.zeros(k - 1)])
    sol = spsolve(kkt, rhs)
    return sol[:k], sol[k:2 * k]


@dataclass(frozen=True)
class RunFit:
    """Longitudinal kinematics of one contiguous run of a track (K samples every dt).

    Attributes:
        track: the track; rows: (K,) indices into its arrays.
        path: (P, 2) reference path [m].
        s_obs: (K,) recorded positions projected onto the path [m]; lateral: (K,) their signed
            offsets [m].
        s: (K,) fitted arc length [m]; v: (K,) fitted speed along the path [m/s];
        u: (K-1,) controls (v_{k+1} - v_k) / dt [m/s^2].
    """

    track: Track
    rows: np.ndarray
    path: np.ndarray
    s_obs: np.ndarray
    lateral: np.ndarray
    s: np.ndarray
    v: np.ndarray
    u: np.ndarray


def _runs(track: Track, dt_ms: int) -> list[np.ndarray]:
    """Row indices of the maximal runs of a track sampled every dt_ms without gaps."""
    breaks = np.flatnonzero(np.diff(track.timestamp_ms) != dt_ms) + 1
    return np.split(np.arange(len(track.timestamp_ms)), breaks)


def fit_track(track: Track, dt_ms: int, min_samples: int = 5,
              path_cutoff_hz: float = PATH_CUTOFF_HZ,
              speed_cutoff_hz: float = SPEED_CUTOFF_HZ) -> list[RunFit]:
    """Reference path, arc length, speed and controls of each contiguous run of a vehicle
    track sampled every dt_ms [ms] (runs shorter than min_samples or hardly moving are left
    out); the cutoffs [Hz] as in fit_reference_path and smooth_arc_length.
    """
    dt_s = dt_ms * 1e-3
    fits = []
    for rows in _runs(track, dt_ms):
        if len(rows) < max(min_samples, 5):
            continue
        path, sigma = fit_reference_path(track.t_s[rows], track.xy[rows], path_cutoff_hz)
        if path is None:
            continue
        s_obs, lateral = project_local(path, track.xy[rows], sigma)
        s, v = smooth_arc_length(s_obs, dt_s, speed_cutoff_hz)
        fits.append(RunFit(track, rows, path, s_obs, lateral, s, v, np.diff(v) / dt_s))
    return fits


def recording_step_ms(tracks: dict[str, Track]) -> int:
    """The recording's sampling step [ms]: the most common step between consecutive samples of
    a track (gaps in a track are longer steps).
    """
    steps = np.concatenate([np.diff(t.timestamp_ms) for t in tracks.values()])
    if len(steps) == 0:
        raise ValueError("recording has no track with two samples: cannot determine dt")
    values, counts = np.unique(steps, return_counts=True)
    return int(values[np.argmax(counts)])


# --------------------------------------------------------------------------------------------
# demonstrations


def replay(demo: Demonstration):
    """Integrate a demonstration's controls with its dynamics.

    Returns:
        s: (T+1,) arc length [m]; v: (T+1,) speed [m/s]; xy: (T+1, 2) positions
        path.point_at(s) [m]; heading: (T+1,) [rad]. Index 0 is the segment start.
    """
    dt = demo.dt_s
    v = demo.v0_mps + dt * np.concatenate([[0.0], np.cumsum(demo.controls_mps2)])
    s = demo.s0_m + np.concatenate([[0.0], np.cumsum(0.5 * dt * (v[1:] + v[:-1]))])
    xy, heading = demo.route.point_at(s)
    return s, v, xy, heading


def _crop_path(path: np.ndarray, s_lo: float, s_hi: float) -> tuple[np.ndarray, float]:
    """Vertices of path covering arc lengths [s_lo, s_hi] [m] (one vertex beyond each end when
    there is one) and the arc length of the first kept vertex [m].
    """
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    i0 = max(int(np.searchsorted(cum, s_lo, side="right")) - 1, 0)
    i1 = min(int(np.searchsorted(cum, s_hi, side="left")), len(path) - 1)
    i1 = max(i1, i0 + 1)
    return path[i0:i1 + 1], float(cum[i0])


def default_v_ref(fits: list[RunFit], min_speed_mps: float) -> float:
    """V_REF_PERCENTILE-th percentile of the fitted speeds [m/s] of all samples of the given
    runs moving at >= min_speed_mps: the 85th-percentile speed, the traffic engineers' usual
    proxy for the desired speed (and basis of speed limits).
    """
    v = np.concatenate([f.v for f in fits]) if fits else np.zeros(0)
    v = v[v >= min_speed_mps]
    if len(v) == 0:
        raise ValueError("no vehicle moves at >= min_speed_mps: cannot choose v_ref_mps; pass it")
    return float(np.percentile(v, V_REF_PERCENTILE))


def interaction_demonstrations(tracks: dict[str, Track], segment_steps: int = 30,
                               stride_steps: int = 10, v_ref_mps: float | None = None,
                               min_speed_mps: float = 1.0, radius_m: float = 50.0,
                               agent_types=("car",), *, expected_dt_s: float | None = 0.1,
                               path_margin_m: float = PATH_MARGIN_M,
                               max_roundtrip_error_m: float = MAX_ROUNDTRIP_ERROR_M,
                               path_cutoff_hz: float = PATH_CUTOFF_HZ,
                               speed_cutoff_hz: float = SPEED_CUTOFF_HZ,
                               ) -> list[Demonstration]:
    """Cut the vehicle tracks of one recording into demonstration segments.

    Every track whose agent_type is in agent_types is an ego: each contiguous run is fitted
    (`fit_track`) and cut into segments of T = segment_steps controls starting every
    stride_steps samples. A segment is dropped

    * if the fitted speed is below min_speed_mps at any of its T+1 samples: the IRL's model
      integrates v_{k+1} = v_k + u_k dt without the limit v >= 0, so near a stop its
      alternatives would reverse, and the demonstrator's zero control while standing is the
      active limit, not a trade-off of its cost;
    * if the controls, replayed with the Demonstration's dynamics (`replay`), miss the recorded
      positions by more than max_roundtrip_error_m at any sample (a tracking glitch the smooth
      path cannot follow); a warning counts these.

    `others` of a segment = every other agent (vehicles, pedestrians, cyclists) recorded at all
    T+1 samples of the segment (the Demonstration has no per-instant mask, so an agent that
    enters or leaves within the segment is left out) and within radius_m of the ego's recorded
    position at the segment start; their recorded positions at the T instants after each step,
    headings psi_rad (vehicles) or direction of motion (pedestrians, `Track.heading_rad`) and
    footprints (pedestrians: PEDESTRIAN_DIAMETER_M disc, is_pedestrian True).

    Args:
        tracks: from read_interaction_csv (one recording).
        segment_steps, stride_steps: T and the shift between segment starts [steps].
        v_ref_mps: reference speed of the speed feature; None: `default_v_ref` of the egos' runs.
        min_speed_mps: see above [m/s]. radius_m: see above [m].
        agent_types: agent_type values that are egos.
        expected_dt_s: the recording's step (`recording_step_ms`) must equal this [s] (INTERACTION
            records at 10 Hz); None accepts any step.
        path_margin_m: each demonstration keeps its reference path from path_margin_m before to
            path_margin_m after the segment (alternative control sequences evaluated by the IRL
            travel further or less far) [m].
        max_roundtrip_error_m: see above [m].
        path_cutoff_hz, speed_cutoff_hz: smoothing of the path and of s(t) (`fit_track`) [Hz].

    Returns:
        Demonstrations in track order then time order: agent "track <id>", source = the ego's
        file name, t0_s = timestamp of the segment start [s], crosswalks (), theta_true and
        beta_true NaN, prev_accel_mps2 = control of the step before (0 at a run's first step).
    """
    if segment_steps < 1 or stride_steps < 1:
        raise ValueError(f"segment_steps and stride_steps must be >= 1, got {segment_steps}, "
                         f"{stride_steps}")
    dt_ms = recording_step_ms(tracks)
    if expected_dt_s is not None and abs(dt_ms * 1e-3 - expected_dt_s) > 1e-6:
        sources = sorted({t.source for t in tracks.values()})
        raise ValueError(f"{', '.join(sources)}: samples are {dt_ms} ms apart, expected "
                         f"{expected_dt_s * 1e3:g} ms (pass expected_dt_s=None to accept)")
    dt_s = dt_ms * 1e-3
    t_steps = segment_steps
    egos = [t for t in tracks.values() if t.agent_type in agent_types]
    fits = [f for t in egos
            for f in fit_track(t, dt_ms, t_steps + 1, path_cutoff_hz, speed_cutoff_hz)]
    if not fits:
        return []
    if v_ref_mps is None:
        v_ref_mps = default_v_ref(fits, min_speed_mps)
    all_tracks = list(tracks.values())
    first = np.array([t.timestamp_ms[0] for t in all_tracks])
    last = np.array([t.timestamp_ms[-1] for t in all_tracks])
    demos, dropped = [], []
    for fit in fits:  # one iteration per run of a track
        ego = fit.track
        stamps = ego.timestamp_ms[fit.rows]
        k = len(stamps)
        starts = np.arange(0, k - t_steps, stride_steps)
        fast = sliding_window_view(fit.v, t_steps + 1).min(axis=1)[starts] >= min_speed_mps
        starts = starts[fast]
        if len(starts) == 0:
            continue
        # the other agents overlapping the run: presence, positions, headings at its samples
        cand = [all_tracks[i] for i in np.flatnonzero((first <= stamps[-1]) & (last >= stamps[0]))
                if all_tracks[i] is not ego]
        n_c = len(cand)
        present = np.zeros((n_c, k), bool)
        oxy, ohead = np.zeros((n_c, k, 2)), np.zeros((n_c, k))
        for c, other in enumerate(cand):  # one iteration per other track
            idx = np.clip(np.searchsorted(other.timestamp_ms, stamps), 0,
                          len(other.timestamp_ms) - 1)
            present[c] = other.timestamp_ms[idx] == stamps
            oxy[c], ohead[c] = other.xy[idx], other.heading_rad()[idx]
        ego_xy = ego.xy[fit.rows]
        whole = sliding_window_view(present, t_steps + 1, axis=1).all(axis=-1)[:, starts]
        near = np.linalg.norm(oxy[:, starts] - ego_xy[starts], axis=-1) <= radius_m
        chosen = whole & near  # (C, n_segments)
        o_len = np.array([o.length_m for o in cand])
        o_wid = np.array([o.width_m for o in cand])
        o_ped = np.array([o.is_pedestrian for o in cand], dtype=bool)
        for j, i in enumerate(starts.tolist()):  # one Demonstration object per segment
            path, s_base = _crop_path(fit.path, fit.s[i] - path_margin_m,
                                      fit.s[i + t_steps] + path_margin_m)
            m = chosen[:, j]
            demo = Demonstration(
                controls_mps2=fit.u[i:i + t_steps], dt_s=dt_s, s0_m=float(fit.s[i] - s_base),
                v0_mps=float(fit.v[i]), prev_accel_mps2=float(fit.u[i - 1]) if i > 0 else 0.0,
                v_ref_mps=float(v_ref_mps), path_xy=path, length_m=ego.length_m,
                width_m=ego.width_m, others_xy=oxy[m, i + 1:i + t_steps + 1],
                others_heading=ohead[m, i + 1:i + t_steps + 1], others_length_m=o_len[m],
                others_width_m=o_wid[m], others_is_pedestrian=o_ped[m], crosswalks=(),
                agent=f"track {ego.track_id}", source=ego.source, t0_s=float(stamps[i]) * 1e-3,
            )
            _, _, xy, _ = replay(demo)
            error = float(np.max(np.linalg.norm(xy - ego_xy[i:i + t_steps + 1], axis=1)))
            if error > max_roundtrip_error_m:
                dropped.append(f"track {ego.track_id} t0={demo.t0_s:g}s ({error:.2f} m)")
                continue
            demos.append(demo)
    if dropped:
        warnings.warn(f"{len(dropped)} segment(s) dropped: replay misses the recorded positions "
                      f"by > {max_roundtrip_error_m} m: {', '.join(dropped[:10])}", stacklevel=2)
    return demos


def recordings(paths) -> list[list[Path]]:
    """Group track files into recordings: files named like INTERACTION's
    ``vehicle_tracks_NNN.csv`` / ``pedestrian_tracks_NNN.csv`` by (directory, NNN); all other
    files together as one recording. A directory stands for the .csv files in it.
    """
    files = []
    for p in map(Path, [paths] if isinstance(paths, (str, Path)) else paths):
        files.extend(sorted(p.glob("*.csv")) if p.is_dir() else [p])
    groups: dict[tuple, list[Path]] = {}
    for f in files:
        match = _RECORDING_NAME.match(f.name)
        key = (str(f.parent.resolve()), match.group(1)) if match else ("", "")
        groups.setdefault(key, []).append(f)
    return [groups[key] for key in sorted(groups)]


def load_interaction(paths, **kwargs) -> list[Demonstration]:
    """Demonstrations from INTERACTION track files: the entry point of `marl-social irl`.

    Args:
        paths: CSV files and/or directories of them, grouped into recordings by `recordings`
            (each read with read_interaction_csv, so a recording's vehicle and pedestrian files
            are merged and different recordings never mix).
        **kwargs: passed to interaction_demonstrations (segment_steps, stride_steps, v_ref_mps,
            min_speed_mps, radius_m, agent_types, ...); a default v_ref is chosen per recording.

    Returns:
        All recordings' demonstrations.
    """
    groups = recordings(paths)
    if not groups:
        raise ValueError(f"load_interaction: no .csv files in {paths}")
    demos = []
    for files in groups:
        demos.extend(interaction_demonstrations(read_interaction_csv(files), **kwargs))
    return demos
