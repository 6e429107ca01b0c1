"""INTERACTION dataset loader: demonstrations for inverse optimal control from real-world tracks.

Tracks in the CSV schema of the INTERACTION dataset (Zhan et al. 2019, interaction-dataset.com).

Input: one recording = the track files of one scene and time span, e.g. ``vehicle_tracks_000.csv``
and ``pedestrian_tracks_000.csv``, with the columns

    track_id, frame_id, timestamp_ms, agent_type, x, y, vx, vy, psi_rad, length, width

(10 Hz, positions of the footprint centres [m], velocities [m/s], heading [rad], footprint [m]).
Pedestrian files ("pedestrian/bicycle", ids like "P1") may leave out or leave empty psi_rad,
length and width. Output: `marl_social.data.demonstrations.Demonstration` segments.

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

Accuracy (tests/data/test_interaction.py: a car on a 30 m radius curve, +1.5 then -2.5 m/s^2 with
1 s jerk-limited transitions, 5 cm Gaussian position noise; mean / worst of 20 noise draws):
controls RMS error 0.17 / 0.20 m/s^2 (0.08-0.10 / 0.16 within the constant phases, up to 0.7
at the transitions), speed RMS 0.05 / 0.06 m/s, path within 0.05 / 0.07 m of the true path
(extension tips 0.14 / 0.28 m), replayed positions within 0.07 / 0.11 m of the true and
0.15 / 0.18 m of the noisy recorded positions.

Modules: `tracks` (reading and validating the CSV files, grouping them into recordings),
`smoothing` (the smoothers), `paths` (reference path, projection, `fit_track`), `segments`
(Demonstration segments, `replay`, `load_interaction`).
"""

from marl_social.data.interaction.paths import (
    END_CHORD_M,
    PATH_CUTOFF_HZ,
    PATH_EXTENSION_M,
    PATH_MIN_SPEED_MPS,
    PATH_SPACING_M,
    PATH_WAVELENGTH_M,
    PROJECTION_WINDOW_M,
    RunFit,
    fit_reference_path,
    fit_track,
    project_local,
)
from marl_social.data.interaction.segments import (
    MAX_ROUNDTRIP_ERROR_M,
    PATH_MARGIN_M,
    V_REF_PERCENTILE,
    SegmentCut,
    default_v_ref,
    interaction_demonstrations,
    load_interaction,
    replay,
)
from marl_social.data.interaction.smoothing import (
    SPEED_CUTOFF_HZ,
    smooth_arc_length,
    whittaker_smooth,
)
from marl_social.data.interaction.tracks import (
    BASE_COLUMNS,
    CSV_COLUMNS,
    PEDESTRIAN_DIAMETER_M,
    PEDESTRIAN_TYPES,
    VEHICLE_COLUMNS,
    Track,
    read_interaction_csv,
    recording_step_ms,
    recordings,
)

__all__ = [
    "BASE_COLUMNS", "CSV_COLUMNS", "END_CHORD_M", "MAX_ROUNDTRIP_ERROR_M", "PATH_CUTOFF_HZ",
    "PATH_EXTENSION_M", "PATH_MARGIN_M", "PATH_MIN_SPEED_MPS", "PATH_SPACING_M",
    "PATH_WAVELENGTH_M", "PEDESTRIAN_DIAMETER_M", "PEDESTRIAN_TYPES", "PROJECTION_WINDOW_M",
    "SPEED_CUTOFF_HZ", "VEHICLE_COLUMNS", "V_REF_PERCENTILE", "RunFit", "SegmentCut", "Track",
    "default_v_ref", "fit_reference_path", "fit_track", "interaction_demonstrations",
    "load_interaction", "project_local", "read_interaction_csv", "recording_step_ms",
    "recordings", "replay", "smooth_arc_length", "whittaker_smooth",
]
