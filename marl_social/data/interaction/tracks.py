"""Read and validate the track files of one INTERACTION recording.

The CSV schema of the INTERACTION dataset (Zhan et al. 2019, interaction-dataset.com): one file
per agent class and recording (``vehicle_tracks_000.csv``, ``pedestrian_tracks_000.csv``), 10 Hz
rows with the columns `CSV_COLUMNS`. `read_interaction_csv` turns the files of one recording into
`Track` objects; `recordings` groups files into recordings; `recording_step_ms` finds the
sampling step.
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from marl_social.data.file_limits import MB, check_file_size

CSV_COLUMNS = ("track_id", "frame_id", "timestamp_ms", "agent_type", "x", "y", "vx", "vy",
               "psi_rad", "length", "width")
BASE_COLUMNS = CSV_COLUMNS[:8]  # required in every file
VEHICLE_COLUMNS = CSV_COLUMNS[8:]  # required (non-empty) for rows that are not pedestrians
PEDESTRIAN_TYPES = frozenset({"pedestrian/bicycle", "pedestrian", "bicycle"})
PEDESTRIAN_DIAMETER_M = 0.6  # footprint of pedestrians and cyclists (length = width) [m]
_MIN_HEADING_SPEED_MPS = 0.2  # below this a pedestrian keeps its last direction of motion [m/s]
# largest magnitude per numeric column: beyond these a value is a corrupt row (and 1e300 m
# coordinates would overflow the path resampling)
COLUMN_LIMITS = {"frame_id": 1e15, "timestamp_ms": 1e15, "x": 1e8, "y": 1e8, "vx": 1e3,
                 "vy": 1e3, "psi_rad": 1e3, "length": 1e3, "width": 1e3}
MAX_CSV_BYTES = 40 * MB  # largest track file read: parsing takes ~27x its size in memory (~1 GB)
MAX_SPEED_MPS = 1000.0  # consecutive samples of a track farther apart than this are corrupt
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
        """(K,) heading [rad].

        psi_rad for vehicles; for pedestrians the direction of motion atan2(vy, vx), held from
        the last sample moving faster than 0.2 m/s (the first such direction before it; 0 if
        the pedestrian never moves).
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
                         f"{column!r} must be {kind}, got {str(values[i])[:40]!r}")
    limit = COLUMN_LIMITS.get(column, np.inf)
    huge = np.abs(out) > limit
    if np.any(huge):
        i = int(np.argmax(huge))
        raise ValueError(f"{path.name} line {lines[i]} (track {track_ids[i]}): column "
                         f"{column!r} must be within +-{limit:g}, got {str(values[i])[:40]!r}")
    return out


def _read_file(path: Path) -> dict[str, Track]:
    """One CSV file -> tracks (see read_interaction_csv)."""
    if not path.is_file():
        raise FileNotFoundError(f"INTERACTION track file {path} does not exist")
    check_file_size(path, MAX_CSV_BYTES, "a track file (its parsed rows take ~27x its size "
                    "in memory; split the recording)")
    try:
        return _parse_file(path)
    except UnicodeDecodeError:
        raise ValueError(f"{path.name}: not a UTF-8 text (CSV) file") from None
    except csv.Error as err:
        raise ValueError(f"{path.name}: not a readable CSV file ({err})") from None


def _parse_file(path: Path) -> dict[str, Track]:
    """One existing CSV file -> tracks (see read_interaction_csv)."""
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

    step_m = np.hypot(np.diff(num["x"][order]), np.diff(num["y"][order]))
    fast = same & (step_m > MAX_SPEED_MPS * np.diff(stamp[order]) / 1000.0)
    if np.any(fast):
        j = int(np.argmax(fast))
        raise ValueError(f"{path.name} line {lines[order][j + 1]} (track {ids[order][j]}): "
                         f"columns 'x', 'y' jump {step_m[j]:.4g} m in "
                         f"{stamp[order][j + 1] - stamp[order][j]} ms (faster than "
                         f"{MAX_SPEED_MPS:g} m/s)")

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
    """Read the track files of ONE recording into tracks keyed by track id.

    One recording is e.g. its vehicle and its pedestrian file.

    Args:
        path_or_paths: a path or a sequence of paths to CSV files in the INTERACTION schema
            (CSV_COLUMNS; psi_rad, length, width only needed for non-pedestrian rows).

    Returns:
        {track_id: Track}, in the order of first appearance. Pedestrian ids without a leading "P"
        get one, so pedestrian and vehicle ids stay distinct.

    Raises:
        FileNotFoundError: a missing file.
        ValueError: naming the file, line / track and column, for a missing column, a
            non-numeric or non-finite value, a non-integral frame_id / timestamp_ms, a duplicate
            (track_id, frame_id), timestamps not increasing with the frame within a track, a
            non-positive length / width, and for the same track id in two files (files of
            different recordings: read them separately, see `load_interaction`).
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


def recording_step_ms(tracks: dict[str, Track]) -> int:
    """The recording's sampling step [ms].

    The most common step between consecutive samples of a track (gaps in a track are longer
    steps).

    Args:
        tracks: {track_id: Track} of one recording.
    """
    steps = np.concatenate([np.diff(t.timestamp_ms) for t in tracks.values()])
    if len(steps) == 0:
        raise ValueError("recording has no track with two samples: cannot determine dt")
    values, counts = np.unique(steps, return_counts=True)
    return int(values[np.argmax(counts)])


def recordings(paths) -> list[list[Path]]:
    """Group track files into recordings.

    Files named like INTERACTION's ``vehicle_tracks_NNN.csv`` / ``pedestrian_tracks_NNN.csv``
    are grouped by (directory, NNN); all other files together as one recording.

    Args:
        paths: a path or a sequence of paths of CSV files or directories (a directory stands
            for the .csv files in it).

    Returns:
        Lists of file paths, one per recording, sorted by (directory, NNN).
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

