"""Demonstrations for inverse optimal control (agents/irl/laplace.py): one documented format.

Driving segments recorded in the simulator (`marl-social record`) or loaded from real-world
tracks (marl_social/data/interaction/).

A `Demonstration` is one vehicle's longitudinal control sequence over T steps of dt along a
reference path, with everything its cost (marl_social/sim/costs.py) depends on:

    u_D = controls_mps2 (T,);  v_{k+1} = v_k + u_k dt (v_0 = v0_mps);
    s_k = s0_m + trapezoidal distance;  pose_k = path.point_at(s_k)

and the other road users' positions at the same T instants (after each step), the crosswalks of
the map, and the speed the speed feature measures against (v_ref_mps).

File format (`save_demonstrations` / `load_demonstrations`): one NumPy ``.npz`` archive
(no pickles), N demonstrations with a common T and dt, others padded to M objects, paths
concatenated:

==========================  ==============  =================================================
key                         shape / dtype   meaning
==========================  ==============  =================================================
format                      () str          "marl-social-demonstrations/1"
dt_s                        () float64      control step [s]
controls_mps2               (N, T) f8       executed longitudinal accelerations [m/s^2]
s0_m, v0_mps                (N,) f8         arc length and speed at the segment start
prev_accel_mps2             (N,) f8         acceleration of the step before (jerk term)
v_ref_mps                   (N,) f8         reference speed of the speed feature [m/s]
length_m, width_m           (N,) f8         the demonstrator's footprint [m]
path_xy                     (P_total, 2)    all reference paths, concatenated [m]
path_offsets                (N+1,) int64    demonstration i's path is path_xy[o[i]:o[i+1]]
others_xy                   (N, M, T, 2)    others' centres at the T instants [m]
others_heading              (N, M, T)       others' headings [rad]
others_length_m, _width_m   (N, M)          others' footprints [m] (pedestrian: diameter)
others_is_pedestrian        (N, M) bool
others_mask                 (N, M) bool     padding is False
crosswalk_center            (K, 2)          the map's crosswalks (shared by all demos)
crosswalk_heading_rad       (K,)            walking direction [rad]
crosswalk_length_m, _width  (K,)            extent along / across the walking direction [m]
theta_true                  (N, 6) f8       the demonstrator's true cost weights
                                            (sim/costs.FEATURE_NAMES), NaN if unknown
beta_true                   (N,) f8         its true rationality, NaN if unknown
agent, source               (N,) str        who demonstrated, where it comes from
t0_s                        (N,) f8         segment start time in its episode / recording [s]
==========================  ==============  =================================================
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from marl_social.data.archive import FLAGS, NUMBERS, TEXT, read_npz, short_reason
from marl_social.sim.costs import N_FEATURES
from marl_social.sim.road_map import Crosswalk, Route

FORMAT = "marl-social-demonstrations/1"
MAX_ACCEL_MPS2 = 100.0  # largest |control| of a demonstration [m/s^2] (~10 g)
MAX_DT_S = 10.0  # longest demonstration step [s]
MAX_SIZE_M = 100.0  # largest length or width of a demonstrator or another agent [m]
ARCHIVE_FIELDS = {  # the arrays of an archive and the dtype kinds each may hold
    **dict.fromkeys(("dt_s", "controls_mps2", "s0_m", "v0_mps", "prev_accel_mps2", "v_ref_mps",
                     "length_m", "width_m", "beta_true", "t0_s", "path_xy", "others_xy",
                     "others_heading", "others_length_m", "others_width_m", "crosswalk_center",
                     "crosswalk_heading_rad", "crosswalk_length_m", "crosswalk_width_m",
                     "theta_true"), NUMBERS),
    "path_offsets": "iu", "others_is_pedestrian": FLAGS, "others_mask": FLAGS,
    "agent": TEXT, "source": TEXT}


@dataclass(frozen=True)
class Demonstration:
    """One demonstration segment (see the module docstring; SI units).

    Attributes:
        controls_mps2: (T,) executed accelerations along the path [m/s^2].
        dt_s: control step [s].
        s0_m, v0_mps, prev_accel_mps2: state at the start [m, m/s, m/s^2].
        v_ref_mps: reference speed of the speed feature [m/s].
        path_xy: (P, 2) reference path polyline [m] (P >= 2).
        length_m, width_m: the demonstrator's footprint [m].
        others_xy: (M, T, 2) others' centres after each step [m]; others_heading (M, T) [rad];
        others_length_m, others_width_m: (M,) [m]; others_is_pedestrian: (M,) bool.
        crosswalks: the map's crosswalks.
        theta_true: (6,) true weights or all NaN; beta_true: true rationality or NaN.
        agent, source: provenance; t0_s: start time in the recording [s].
    """

    controls_mps2: np.ndarray
    dt_s: float
    s0_m: float
    v0_mps: float
    prev_accel_mps2: float
    v_ref_mps: float
    path_xy: np.ndarray
    length_m: float = 4.5
    width_m: float = 1.8
    others_xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 1, 2)))
    others_heading: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    others_length_m: np.ndarray = field(default_factory=lambda: np.zeros(0))
    others_width_m: np.ndarray = field(default_factory=lambda: np.zeros(0))
    others_is_pedestrian: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    crosswalks: tuple = ()
    theta_true: np.ndarray = field(default_factory=lambda: np.full(N_FEATURES, np.nan))
    beta_true: float = float("nan")
    agent: str = ""
    source: str = ""
    t0_s: float = 0.0

    def __post_init__(self):
        who = f"demonstration {self.agent or '?'}@{self.source or '?'} t0={self.t0_s:g}s"
        u = np.asarray(self.controls_mps2, dtype=np.float64)
        if u.ndim != 1 or len(u) < 1 or not np.all(np.isfinite(u)):
            raise ValueError(f"{who}: controls_mps2 must be a finite (T,) array, got shape "
                             f"{u.shape}")
        if np.max(np.abs(u)) > MAX_ACCEL_MPS2:
            raise ValueError(f"{who}: controls_mps2 must lie within +-{MAX_ACCEL_MPS2:g} m/s^2, "
                             f"got {np.max(np.abs(u)):.3g}")
        object.__setattr__(self, "controls_mps2", u)
        for name, high in (("dt_s", MAX_DT_S), ("length_m", MAX_SIZE_M), ("width_m", MAX_SIZE_M)):
            value = getattr(self, name)
            if isinstance(value, (bool, np.bool_)) or not 0 < value <= high:
                raise ValueError(f"{who}: {name} must be a number in (0, {high:g}], got {value!r}")
        for name in ("s0_m", "v0_mps", "prev_accel_mps2", "v_ref_mps"):
            if not np.isfinite(getattr(self, name)):
                raise ValueError(f"{who}: {name} must be finite, got {getattr(self, name)}")
        object.__setattr__(self, "path_xy", np.asarray(self.path_xy, dtype=np.float64))
        Route(self.path_xy, f"{who}: path_xy")  # validates the polyline
        xy = np.asarray(self.others_xy, dtype=np.float64)
        m = xy.shape[0]
        if xy.ndim != 3 or xy.shape[2] != 2 or (m and xy.shape[1] != len(u)):
            raise ValueError(f"{who}: others_xy must be (M, T={len(u)}, 2), got {xy.shape}")
        if m == 0:
            xy = np.zeros((0, len(u), 2))
        heading = np.broadcast_to(np.asarray(self.others_heading, dtype=np.float64),
                                  xy.shape[:2]).copy() if m else np.zeros((0, len(u)))
        if not (np.all(np.isfinite(xy)) and np.all(np.isfinite(heading))):
            raise ValueError(f"{who}: others_xy / others_heading must be finite")
        object.__setattr__(self, "others_xy", xy)
        object.__setattr__(self, "others_heading", heading)
        for name, dtype in (("others_length_m", np.float64), ("others_width_m", np.float64),
                            ("others_is_pedestrian", bool)):
            arr = np.asarray(getattr(self, name), dtype=dtype).reshape(-1)
            if arr.shape != (m,):
                raise ValueError(f"{who}: {name} must have shape ({m},), got {arr.shape}")
            if dtype is np.float64 and not np.all((arr > 0) & (arr <= MAX_SIZE_M)):
                raise ValueError(f"{who}: {name} must lie in (0, {MAX_SIZE_M:g}] m")
            object.__setattr__(self, name, arr)
        theta = np.asarray(self.theta_true, dtype=np.float64).reshape(-1)
        if theta.shape != (N_FEATURES,):
            raise ValueError(f"{who}: theta_true must have {N_FEATURES} values")
        object.__setattr__(self, "theta_true", theta)
        object.__setattr__(self, "crosswalks", tuple(self.crosswalks))

    @property
    def n_steps(self) -> int:
        return len(self.controls_mps2)

    @property
    def route(self) -> Route:
        return Route(self.path_xy, f"path of {self.agent or 'demonstration'}")


def _same_crosswalks(a: tuple, b: tuple) -> bool:
    return len(a) == len(b) and all(
        np.allclose(x.center, y.center) and x.walk_heading_rad == y.walk_heading_rad
        and x.length_m == y.length_m and x.width_m == y.width_m for x, y in zip(a, b))


def save_demonstrations(path, demos: list[Demonstration]) -> Path:
    """Write demonstrations (common T and dt, shared crosswalks) to one .npz file."""
    path = Path(path)
    if not demos:
        raise ValueError("save_demonstrations: no demonstrations to write")
    t, dt = demos[0].n_steps, demos[0].dt_s
    for d in demos:
        if d.n_steps != t or d.dt_s != dt:
            raise ValueError(f"save_demonstrations: all segments need T={t}, dt={dt}; "
                             f"{d.agent}@{d.source} t0={d.t0_s} has T={d.n_steps}, dt={d.dt_s}")
        if not _same_crosswalks(d.crosswalks, demos[0].crosswalks):
            raise ValueError("save_demonstrations: all segments must share the crosswalks")
    n, m = len(demos), max(len(d.others_length_m) for d in demos)
    others_xy = np.zeros((n, m, t, 2))
    others_heading = np.zeros((n, m, t))
    others_len, others_wid = np.zeros((n, m)), np.zeros((n, m))
    others_ped, others_mask = np.zeros((n, m), bool), np.zeros((n, m), bool)
    for i, d in enumerate(demos):
        k = len(d.others_length_m)
        others_xy[i, :k], others_heading[i, :k] = d.others_xy, d.others_heading
        others_len[i, :k], others_wid[i, :k] = d.others_length_m, d.others_width_m
        others_ped[i, :k], others_mask[i, :k] = d.others_is_pedestrian, True
    cws = demos[0].crosswalks
    offsets = np.concatenate([[0], np.cumsum([len(d.path_xy) for d in demos])]).astype(np.int64)
    arrays = {
        "format": np.array(FORMAT), "dt_s": np.array(dt),
        "controls_mps2": np.stack([d.controls_mps2 for d in demos]),
        **{key: np.array([getattr(d, key) for d in demos], dtype=np.float64)
           for key in ("s0_m", "v0_mps", "prev_accel_mps2", "v_ref_mps", "length_m", "width_m",
                       "beta_true", "t0_s")},
        "path_xy": np.concatenate([d.path_xy for d in demos]), "path_offsets": offsets,
        "others_xy": others_xy, "others_heading": others_heading,
        "others_length_m": others_len, "others_width_m": others_wid,
        "others_is_pedestrian": others_ped, "others_mask": others_mask,
        "crosswalk_center": np.array([c.center for c in cws]).reshape(-1, 2),
        "crosswalk_heading_rad": np.array([c.walk_heading_rad for c in cws], dtype=np.float64),
        "crosswalk_length_m": np.array([c.length_m for c in cws], dtype=np.float64),
        "crosswalk_width_m": np.array([c.width_m for c in cws], dtype=np.float64),
        "theta_true": np.stack([d.theta_true for d in demos]),
        "agent": np.array([d.agent for d in demos]), "source": np.array([d.source for d in demos]),
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    return path


def load_demonstrations(path) -> list[Demonstration]:
    """Read a file written by `save_demonstrations` (clear errors for other files)."""
    path = Path(path)
    d = read_npz(path, "demonstrations", FORMAT, ARCHIVE_FIELDS)
    try:
        return _demonstrations(d)
    except (ValueError, TypeError, IndexError, KeyError, OverflowError) as err:
        raise ValueError(f"{path}: inconsistent demonstrations archive "
                         f"({short_reason(err)})") from None


def _demonstrations(d: dict[str, np.ndarray]) -> list[Demonstration]:
    """The Demonstrations of an archive's arrays (errors on inconsistent ones)."""
    cws = tuple(Crosswalk(c, float(h), float(ln), float(w)) for c, h, ln, w in zip(
        d["crosswalk_center"], d["crosswalk_heading_rad"], d["crosswalk_length_m"],
        d["crosswalk_width_m"]))
    off = d["path_offsets"]
    if len(off) != len(d["controls_mps2"]) + 1 or np.any(np.diff(off) < 0) or (
            len(off) and (off[0] < 0 or off[-1] > len(d["path_xy"]))):
        raise ValueError("field 'path_offsets' does not match 'path_xy' and 'controls_mps2'")
    demos = []
    for i in range(len(d["controls_mps2"])):
        mask = d["others_mask"][i]
        demos.append(Demonstration(
            controls_mps2=d["controls_mps2"][i], dt_s=float(d["dt_s"]),
            s0_m=float(d["s0_m"][i]), v0_mps=float(d["v0_mps"][i]),
            prev_accel_mps2=float(d["prev_accel_mps2"][i]), v_ref_mps=float(d["v_ref_mps"][i]),
            path_xy=d["path_xy"][off[i]:off[i + 1]], length_m=float(d["length_m"][i]),
            width_m=float(d["width_m"][i]), others_xy=d["others_xy"][i][mask],
            others_heading=d["others_heading"][i][mask],
            others_length_m=d["others_length_m"][i][mask],
            others_width_m=d["others_width_m"][i][mask],
            others_is_pedestrian=d["others_is_pedestrian"][i][mask], crosswalks=cws,
            theta_true=d["theta_true"][i], beta_true=float(d["beta_true"][i]),
            agent=str(d["agent"][i]), source=str(d["source"][i]), t0_s=float(d["t0_s"][i]),
        ))
    return demos
