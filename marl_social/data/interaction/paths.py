"""Reference path of a vehicle track, projections onto it, and the fitted run kinematics.

`fit_track` fits path, arc length, speed and controls of each contiguous run of a track.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marl_social.data.interaction.smoothing import (
    SPEED_CUTOFF_HZ,
    smooth_arc_length,
    whittaker_smooth,
)
from marl_social.data.interaction.tracks import Track
from marl_social.sim.road_map import Route

PATH_CUTOFF_HZ = 1.0  # x(t), y(t) smoothing: gain 1/2 at this frequency [Hz]
PATH_SPACING_M = 0.5  # vertex spacing of the reference path [m]
PATH_EXTENSION_M = 5.0  # straight extension beyond both ends of a track's path [m]
END_CHORD_M = 2.0  # the extensions follow the chord over the path's first / last 2 m
PATH_MIN_SPEED_MPS = 0.5  # the path skips where the smoothed x(t), y(t) move slower [m/s]
PATH_WAVELENGTH_M = 5.0  # second, spatial smoothing of the path: gain 1/2 at this wavelength
PROJECTION_WINDOW_M = 5.0  # projections search this far from the smoothed curve's own s [m]
_SUBSAMPLES = 10  # dense evaluation of the path splines per recorded step


def _resample(points: np.ndarray, spacing_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Resample a polyline by arc length.

    Polyline points (N, 2) [m] -> (n+1, 2) points equally spaced by ~spacing_m along it and
    the arc length of each input point (N,) [m].
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
        spacing_m: vertex spacing of the path [m].
        extension_m: straight extension beyond both ends along the chords over their last
            END_CHORD_M [m].

    Returns:
        path: (P, 2) polyline [m] in travel order, or None if the smoothed curve is shorter than
        3.5 spacing_m (the agent hardly moves); sigma: (K,) arc length along that path of the
        smoothed curve at each sample time [m] (where the projection search starts).
    """
    t = np.asarray(t_s, dtype=np.float64)
    rel = t - t[0]
    dt = float(rel[-1] / (len(t) - 1))
    from scipy.interpolate import CubicSpline  # here: it imports scipy.optimize (~0.7 s)

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
        path: (P, 2) polyline [m].
        xy: (K, 2) points [m].
        s_guess: (K,) arc lengths [m] near which each point's closest point lies.
        window_m: half-width of the search [m].

    Returns:
        s: (K,) arc length of the closest point within the window [m]; lateral: (K,) signed
        offset, left of travel positive [m]. Same convention as road_map.Route.project.
    """
    route = Route(path, "reference path")
    n_seg = len(route.segment_length_m)
    w = math.ceil(window_m / float(np.min(route.segment_length_m))) + 1
    w = min(w, n_seg)
    k0 = np.clip(np.searchsorted(route.vertex_s_m, s_guess, side="right") - 1, 0, n_seg - 1)
    cand = np.clip(k0[:, None] + np.arange(-w, w + 1), 0, n_seg - 1)  # (K, 2w+1)
    rel = np.asarray(xy, dtype=np.float64)[:, None, :] - route.segment_start_m[cand]
    direction = route.segment_direction[cand]
    along = np.clip(np.sum(rel * direction, axis=-1), 0.0, route.segment_length_m[cand])
    d2 = np.sum((rel - along[..., None] * direction) ** 2, axis=-1)
    j = np.argmin(d2, axis=1)[:, None]
    k = np.take_along_axis(cand, j, axis=1)[:, 0]
    a = np.take_along_axis(along, j, axis=1)[:, 0]
    r = np.take_along_axis(rel, j[..., None], axis=1)[:, 0]
    lateral = route.segment_direction[k, 0] * r[:, 1] - route.segment_direction[k, 1] * r[:, 0]
    return route.vertex_s_m[k] + a, lateral



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
    """Reference path, arc length, speed and controls of each contiguous run of a vehicle track.

    Args:
        track: a vehicle track.
        dt_ms: the recording's sampling step [ms]; runs are maximal stretches without gaps.
        min_samples: runs shorter than this (or hardly moving) are left out.
        path_cutoff_hz: smoothing of x(t), y(t), as in fit_reference_path [Hz].
        speed_cutoff_hz: smoothing of s(t), as in smooth_arc_length [Hz].

    Returns:
        One RunFit per fitted run, in time order.
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
