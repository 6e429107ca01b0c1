"""Cut fitted vehicle tracks into Demonstration segments, replay them, load whole recordings.

`load_interaction` (the entry point of `marl-social irl`) reads INTERACTION recordings and
returns their demonstrations.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from tqdm import tqdm

from marl_social.data.demonstrations import Demonstration
from marl_social.data.interaction.paths import PATH_CUTOFF_HZ, RunFit, fit_track
from marl_social.data.interaction.smoothing import SPEED_CUTOFF_HZ
from marl_social.data.interaction.tracks import (
    Track,
    read_interaction_csv,
    recording_step_ms,
    recordings,
)

PATH_MARGIN_M = 30.0  # path kept in a demonstration beyond the segment's ends [m]
V_REF_PERCENTILE = 85.0  # default v_ref: this percentile of the moving vehicles' speeds
PROGRESS_MIN_RUNS = 50  # recordings of this many runs of tracks or more show a progress bar
MAX_ROUNDTRIP_ERROR_M = 0.5  # segments whose replay misses the record by more are dropped [m]


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
    """Crop a polyline to an arc-length interval.

    Returns the vertices of path (P, 2) [m] covering arc lengths [s_lo, s_hi] [m] (one vertex
    beyond each end when there is one) and the arc length of the first kept vertex [m].
    """
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    i0 = max(int(np.searchsorted(cum, s_lo, side="right")) - 1, 0)
    i1 = min(int(np.searchsorted(cum, s_hi, side="left")), len(path) - 1)
    i1 = max(i1, i0 + 1)
    return path[i0:i1 + 1], float(cum[i0])


def default_v_ref(fits: list[RunFit], min_speed_mps: float) -> float:
    """Default reference speed [m/s]: the V_REF_PERCENTILE-th percentile of the fitted speeds.

    Of all samples of the given runs moving at >= min_speed_mps [m/s]: the 85th-percentile
    speed, the traffic engineers' usual proxy for the desired speed (and basis of speed limits).
    """
    v = np.concatenate([f.v for f in fits]) if fits else np.zeros(0)
    v = v[v >= min_speed_mps]
    if len(v) == 0:
        raise ValueError("no vehicle moves at >= min_speed_mps: cannot choose v_ref_mps; pass it")
    return float(np.percentile(v, V_REF_PERCENTILE))


@dataclass(frozen=True)
class SegmentCut:
    """How `interaction_demonstrations` cuts tracks into demonstration segments.

    Attributes:
        segment_steps: T, the controls per segment [steps].
        stride_steps: the shift between segment starts [steps].
        v_ref_mps: reference speed of the speed feature; None: `default_v_ref` of the egos'
            runs [m/s].
        min_speed_mps: segments slower than this at any sample are dropped [m/s].
        radius_m: other agents farther than this from the ego at the segment start are left
            out [m].
        agent_types: agent_type values that are egos.
        expected_dt_s: the recording's step (`recording_step_ms`) must equal this [s]
            (INTERACTION records at 10 Hz); None accepts any step.
        path_margin_m: each demonstration keeps its reference path from path_margin_m before
            to path_margin_m after the segment (alternative control sequences evaluated by the
            IRL travel further or less far) [m].
        max_roundtrip_error_m: segments whose replay misses the record by more are dropped [m].
        path_cutoff_hz: smoothing of the path (`fit_track`) [Hz].
        speed_cutoff_hz: smoothing of s(t) (`fit_track`) [Hz].
    """

    segment_steps: int = 30
    stride_steps: int = 10
    v_ref_mps: float | None = None
    min_speed_mps: float = 1.0
    radius_m: float = 50.0
    agent_types: tuple[str, ...] = ("car",)
    expected_dt_s: float | None = 0.1
    path_margin_m: float = PATH_MARGIN_M
    max_roundtrip_error_m: float = MAX_ROUNDTRIP_ERROR_M
    path_cutoff_hz: float = PATH_CUTOFF_HZ
    speed_cutoff_hz: float = SPEED_CUTOFF_HZ


def interaction_demonstrations(tracks: dict[str, Track],
                               cut: SegmentCut = SegmentCut()) -> list[Demonstration]:
    """Cut the vehicle tracks of one recording into demonstration segments.

    Every track whose agent_type is in cut.agent_types is an ego: each contiguous run is fitted
    (`fit_track`) and cut into segments of T = cut.segment_steps controls starting every
    cut.stride_steps samples. A segment is dropped

    * if the fitted speed is below cut.min_speed_mps at any of its T+1 samples: the IRL's model
      integrates v_{k+1} = v_k + u_k dt without the limit v >= 0, so near a stop its
      alternatives would reverse, and the demonstrator's zero control while standing is the
      active limit, not a trade-off of its cost;
    * if the controls, replayed with the Demonstration's dynamics (`replay`), miss the recorded
      positions by more than cut.max_roundtrip_error_m at any sample (a tracking glitch the
      smooth path cannot follow); a warning counts these.

    `others` of a segment = every other agent (vehicles, pedestrians, cyclists) recorded at all
    T+1 samples of the segment (the Demonstration has no per-instant mask, so an agent that
    enters or leaves within the segment is left out) and within cut.radius_m of the ego's
    recorded position at the segment start; their recorded positions at the T instants after
    each step, headings psi_rad (vehicles) or direction of motion (pedestrians,
    `Track.heading_rad`) and footprints (pedestrians: PEDESTRIAN_DIAMETER_M disc,
    is_pedestrian True).

    Args:
        tracks: from read_interaction_csv (one recording).
        cut: the segment length and stride, v_ref and the filters (`SegmentCut`).

    Returns:
        Demonstrations in track order then time order: agent "track <id>", source = the ego's
        file name, t0_s = timestamp of the segment start [s], crosswalks (), theta_true and
        beta_true NaN, prev_accel_mps2 = control of the step before (0 at a run's first step).
    """
    segment_steps, stride_steps, v_ref_mps = cut.segment_steps, cut.stride_steps, cut.v_ref_mps
    min_speed_mps, expected_dt_s = cut.min_speed_mps, cut.expected_dt_s
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
    egos = [t for t in tracks.values() if t.agent_type in cut.agent_types]
    fits = [f for t in egos
            for f in fit_track(t, dt_ms, t_steps + 1, cut.path_cutoff_hz, cut.speed_cutoff_hz)]
    if not fits:
        return []
    if v_ref_mps is None:
        v_ref_mps = default_v_ref(fits, min_speed_mps)
    all_tracks = list(tracks.values())
    first = np.array([t.timestamp_ms[0] for t in all_tracks])
    last = np.array([t.timestamp_ms[-1] for t in all_tracks])
    demos, dropped = [], []
    progress = tqdm(fits, desc="cutting tracks into segments", unit="run", leave=False,
                    disable=len(fits) < PROGRESS_MIN_RUNS, dynamic_ncols=True)
    for fit in progress:  # one iteration per run of a track
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
        near = np.linalg.norm(oxy[:, starts] - ego_xy[starts], axis=-1) <= cut.radius_m
        chosen = whole & near  # (C, n_segments)
        o_len = np.array([o.length_m for o in cand])
        o_wid = np.array([o.width_m for o in cand])
        o_ped = np.array([o.is_pedestrian for o in cand], dtype=bool)
        for j, i in enumerate(starts.tolist()):  # one Demonstration object per segment
            path, s_base = _crop_path(fit.path, fit.s[i] - cut.path_margin_m,
                                      fit.s[i + t_steps] + cut.path_margin_m)
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
            if error > cut.max_roundtrip_error_m:
                dropped.append(f"track {ego.track_id} t0={demo.t0_s:g}s ({error:.2f} m)")
                continue
            demos.append(demo)
    if dropped:
        warnings.warn(f"{len(dropped)} segment(s) dropped: replay misses the recorded positions "
                      f"by > {cut.max_roundtrip_error_m} m: {', '.join(dropped[:10])}",
                      stacklevel=2)
    return demos



def load_interaction(paths, cut: SegmentCut = SegmentCut()) -> list[Demonstration]:
    """Demonstrations from INTERACTION track files: the entry point of `marl-social irl`.

    Args:
        paths: CSV files and/or directories of them, grouped into recordings by `recordings`
            (each read with read_interaction_csv, so a recording's vehicle and pedestrian files
            are merged and different recordings never mix).
        cut: how interaction_demonstrations cuts the tracks (`SegmentCut`); with its v_ref_mps
            None a default v_ref is chosen per recording.

    Returns:
        All recordings' demonstrations.
    """
    groups = recordings(paths)
    if not groups:
        raise ValueError(f"load_interaction: no .csv files in {paths}")
    demos = []
    for files in groups:
        demos.extend(interaction_demonstrations(read_interaction_csv(files), cut))
    return demos
