"""Hypotheses over hidden agents: (kind, path, progress bin, speed bin) with a motion model.

The hidden physical states x_l, l = 1..L (section III-B-2) are "none" (no hidden agent) and,
for every path a hidden agent may take, one hypothesis per (progress bin, speed bin): "an
agent of this kind is `progress_m` along this path now and moves at `speed_mps`". A path is a
polyline with arc length (`path_xy`, `path_dir`): the two walking directions of every
crosswalk (kind "pedestrian", a straight 2-point path from the curb entry to the far entry,
`crosswalk_hypotheses`), and the lanes that cross or merge into the robot's route with the
right of way there (kind "vehicle", the lane's centre line, curved lanes too; conflicts.py).

Progress bin 0 is the entry (a pedestrian's curb entry, the paper's "steps off the curb now";
a vehicle's most upstream bin); the others are further along, so that an agent out there has a
state that keeps moving. `motion_transition` is the motion model: each step a hypothesis' mass
moves to the next progress bin with probability speed * dt / bin length (the expected progress
is the speed), leaves for "none" after the last bin (a pedestrian has crossed, a vehicle has
passed the conflict), new agents arrive at the entry bins (a hazard rate per kind) and
hypothesised agents vanish at the same rate (beliefs never lock).

Each present hypothesis has a region, (K, 2) sample points [m] of where its agent is now,
which the robot's depth rays can show empty (negative information), and `matches`, whether a
seen object is its agent (positive information; own_sensors.py).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from marl_social.sim.road_map import Crosswalk, RoadMap, Route

PEDESTRIAN_DIAMETER_M = 0.6  # footprint of a hypothesised pedestrian [m]
REGION_BEHIND_M = 0.5  # a pedestrian's region starts this far behind its progress [m]
REGION_AHEAD_ENTRY_M = 1.0  # the entry bin's region reaches this far past the curb [m]
REGION_EDGE_M = 0.5  # region points stay this far inside the crosswalk's side edges [m]
REGION_N_ALONG = 5  # region sample points along the path
REGION_N_ACROSS = 3  # region sample points across it
MATCH_MARGIN_M = 1.0  # a detection this far outside a hypothesis' region can match it [m]
VEHICLE_MATCH_HEADING_RAD = math.radians(45.0)  # a seen car's heading vs. the lane's [rad]
KINDS = ("pedestrian", "vehicle")


@dataclass(frozen=True, eq=False)
class Hypothesis:
    """A hidden agent on a path at a progress and speed bin (or "none").

    Attributes:
        name: "none", or "<path>_p<progress bin>_v<speed bin>"; with one bin of each the
            path's name alone ("crossing_right", "crossing_left", "crossing<i>_<side>").
        present: False only for "none".
        start_xy: (2,) the path's start: the curb entry of a crosswalk, a lane's first point
            [m].
        walk_dir: (2,) unit vector of the path where the agent is now (a crosswalk: across
            the road).
        walk_speed_mps: the speed bin's speed [m/s].
        walk_length_m: the path's length [m]; a pedestrian stops at its end (the far entry), a
            vehicle drives on along the lane's last segment.
        curb_offset_m: from start_xy to the curb (the crosswalk's end) [m]; 0 for vehicles.
        half_width_m: half the crosswalk's extent along the road, half a lane's width [m].
        crosswalk_index: index into RoadMap.crosswalks (-1 for "none" and vehicles).
        kind: "pedestrian" or "vehicle", "" for "none".
        path: the path's name ("crossing_right", "vehicle_<lane name>"; the hypothesis'
            group), "" for "none".
        progress_m: where along the path the agent is now [m].
        progress_bin: index of the progress bin (0: the entry).
        speed_bin: index of the speed bin.
        bin_length_m: length of a progress bin [m] (the motion model's step).
        path_xy: (P, 2) the path's vertices [m], path_xy[0] = start_xy (None for "none").
        path_dir: (P - 1, 2) unit directions of the path's segments.
        length_m: footprint length of the hypothesised agent [m].
        width_m: footprint width of the hypothesised agent [m].
        speed_range_mps: (lo, hi) along-path speeds of a seen vehicle that is this
            hypothesis' agent [m/s] (vehicles only).
        lane_index: index into RoadMap.lanes of a vehicle's lane (-1 otherwise).
        conflict_m: arc length along the path where it meets the robot's route [m] (vehicles;
            0 for pedestrians).
    """

    name: str
    present: bool
    start_xy: np.ndarray | None = None
    walk_dir: np.ndarray | None = None
    walk_speed_mps: float = 0.0
    walk_length_m: float = 0.0
    curb_offset_m: float = 0.0
    half_width_m: float = 0.0
    crosswalk_index: int = -1
    kind: str = ""
    path: str = ""
    progress_m: float = 0.0
    progress_bin: int = 0
    speed_bin: int = 0
    bin_length_m: float = 0.0
    path_xy: np.ndarray | None = None
    path_dir: np.ndarray | None = None
    length_m: float = PEDESTRIAN_DIAMETER_M
    width_m: float = PEDESTRIAN_DIAMETER_M
    speed_range_mps: tuple = (0.0, math.inf)
    lane_index: int = -1
    conflict_m: float = 0.0
    _cum_m: np.ndarray = field(init=False, repr=False, default=None)
    _seg_heading: tuple = field(init=False, repr=False, default=())
    _route: Route | None = field(init=False, repr=False, default=None)

    def __post_init__(self):
        """Default a straight path from start_xy along walk_dir; cache arc lengths, headings."""
        if not self.present:
            return
        if self.kind not in KINDS:
            raise ValueError(f"hypothesis {self.name!r}: kind must be one of {KINDS}, "
                             f"got {self.kind!r}")
        if self.path_xy is None:
            end = self.start_xy + self.walk_length_m * self.walk_dir
            object.__setattr__(self, "path_xy", np.array([self.start_xy, end]))
            object.__setattr__(self, "path_dir", np.array([self.walk_dir]))
        seg = np.linalg.norm(np.diff(self.path_xy, axis=0), axis=1)
        object.__setattr__(self, "_cum_m", np.concatenate([[0.0], np.cumsum(seg)]))
        object.__setattr__(self, "_seg_heading",
                           tuple(math.atan2(d[1], d[0]) for d in self.path_dir))
        object.__setattr__(self, "_route", Route(self.path_xy, self.path or self.name))

    # -- the path -------------------------------------------------------------------------------
    def _segment(self, s) -> np.ndarray:
        """(...) index of the path segment at arc lengths s (...) [m] (end segments extend)."""
        k = np.searchsorted(self._cum_m, s, side="right") - 1
        return np.clip(k, 0, len(self.path_dir) - 1)

    def path_point(self, s) -> tuple[np.ndarray, np.ndarray]:
        """Points (..., 2) [m] and unit directions (..., 2) at arc lengths s (...) [m].

        Beyond the path's ends the end segments extend.
        """
        s = np.asarray(s, dtype=np.float64)
        k = self._segment(s)
        return self.path_xy[k] + (s - self._cum_m[k])[..., None] * self.path_dir[k], \
            self.path_dir[k]

    def _progress_at(self, times_s) -> np.ndarray:
        """(T,) arc length [m] at future times (T,) [s]: a pedestrian stops at the path's end."""
        t = np.asarray(times_s, dtype=np.float64)
        upper = self.walk_length_m if self.kind == "pedestrian" else np.inf
        return np.clip(self.progress_m + self.walk_speed_mps * t, 0.0, upper)

    def predict_xy(self, times_s) -> np.ndarray:
        """Positions (T, 2) [m] at future times (T,) [s].

        The agent moves on from progress_m at walk_speed_mps along its path; a pedestrian stops
        at the path's end (the far entry), a vehicle drives on. Raises ValueError for "none".
        """
        if not self.present:
            raise ValueError(f"hypothesis {self.name!r}: has no agent to predict")
        return self.path_point(self._progress_at(times_s))[0]

    def predict_heading(self, times_s) -> np.ndarray:
        """Headings (T,) [rad] along the path at future times (T,) [s] (see predict_xy)."""
        if not self.present:
            raise ValueError(f"hypothesis {self.name!r}: has no agent to predict")
        if len(self._seg_heading) == 1:
            return np.full(np.shape(times_s), self._seg_heading[0])
        k = self._segment(self._progress_at(times_s))
        return np.asarray(self._seg_heading)[k]

    def corridor_coords(self, xy) -> tuple[np.ndarray, np.ndarray]:
        """Coordinates of points (n, 2) [m] in the frame of the path's first segment.

        Returns `along` from start_xy in walk_dir and `across` (left of walk_dir) [m], each (n,)
        (a crosswalk's frame; vehicles use `path_coords`).
        """
        rel = np.asarray(xy, dtype=np.float64) - self.start_xy
        along = rel @ self.walk_dir
        across = rel @ np.array([-self.walk_dir[1], self.walk_dir[0]])
        return along, across

    def path_coords(self, xy) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Arc length (n,) [m], signed lateral offset (n,) [m] and path heading (n,) [rad].

        Of points (n, 2) [m] projected onto the path polyline (sim.road_map.Route.project).
        """
        return self._route.project(np.asarray(xy, dtype=np.float64))

    # -- where the agent is now -----------------------------------------------------------------
    def _along_range(self) -> tuple[float, float]:
        """Where along the path [m] the agent of this hypothesis is now (its bin's footprint)."""
        if self.kind == "vehicle":
            half = 0.5 * self.length_m
            return self.progress_m - half, self.progress_m + self.bin_length_m + half
        if self.progress_bin == 0:
            return self.progress_m - REGION_BEHIND_M, self.curb_offset_m + REGION_AHEAD_ENTRY_M
        return self.progress_m - REGION_BEHIND_M, self.progress_m + self.bin_length_m

    def region(self) -> np.ndarray:
        """(K, 2) sample points [m] of where the agent is now.

        REGION_N_ALONG x REGION_N_ACROSS points over the progress bin: a pedestrian's across
        the crosswalk's width (the entry bin: the curb entry area and the first metre of road),
        a vehicle's over its footprint anywhere on its bin. Empty (0, 2) for "none".
        """
        if not self.present:
            return np.zeros((0, 2))
        lo, hi = self._along_range()
        along = np.linspace(lo, hi, REGION_N_ALONG)
        if self.kind == "vehicle":
            half = 0.5 * self.width_m
        else:
            half = max(self.half_width_m - REGION_EDGE_M, 0.0)
        across = np.linspace(-half, half, REGION_N_ACROSS)
        base, direction = self.path_point(along)
        normal = np.stack([-direction[:, 1], direction[:, 0]], axis=-1)
        pts = base[:, None, :] + across[None, :, None] * normal[:, None, :]
        return pts.reshape(-1, 2)

    def matches(self, xy, velocity, walking_speed_min_mps: float) -> bool:
        """Whether one of the seen agents (n, 2) [m], (n, 2) [m/s] is this hypothesis' agent.

        A pedestrian must be in the bin's region (+- MATCH_MARGIN_M) and either on the road
        not walking against the path, or walking along it at >= walking_speed_min_mps; one
        standing on the sidewalk matches nothing. A vehicle must be on the lane (its
        half width + MATCH_MARGIN_M), within the bin's footprint (+- MATCH_MARGIN_M), heading
        along the lane (VEHICLE_MATCH_HEADING_RAD) at a speed in speed_range_mps.

        Args:
            xy: (n, 2) seen agents' positions [m] (of this hypothesis' kind).
            velocity: (n, 2) their velocities [m/s].
            walking_speed_min_mps: pedestrians only.
        """
        if not self.present or len(xy) == 0:
            return False
        if self.kind == "vehicle":
            return self._matches_vehicle(xy, velocity)
        along, across = self.corridor_coords(xy)
        v_along = np.asarray(velocity, dtype=np.float64) @ self.walk_dir
        lo, hi = self._along_range()
        road_end = self.walk_length_m - self.curb_offset_m
        inside = ((np.abs(across) <= self.half_width_m + MATCH_MARGIN_M)
                  & (along >= lo - MATCH_MARGIN_M) & (along <= min(hi + MATCH_MARGIN_M, road_end)))
        on_road = (along >= self.curb_offset_m) & (along <= road_end)
        crossing = (on_road & (v_along > -walking_speed_min_mps)) | (
            v_along >= walking_speed_min_mps)
        return bool(np.any(inside & crossing))

    def _matches_vehicle(self, xy, velocity) -> bool:
        """`matches` for a vehicle: on the lane, in the bin, along it, in the speed bin."""
        s, lateral, heading = self.path_coords(xy)
        vel = np.asarray(velocity, dtype=np.float64)
        speed = np.hypot(vel[:, 0], vel[:, 1])
        v_along = vel[:, 0] * np.cos(heading) + vel[:, 1] * np.sin(heading)
        lo, hi = self._along_range()
        inside = ((np.abs(lateral) <= self.half_width_m + MATCH_MARGIN_M)
                  & (s >= lo - MATCH_MARGIN_M) & (s <= hi + MATCH_MARGIN_M))
        along = v_along >= speed * math.cos(VEHICLE_MATCH_HEADING_RAD)
        lo_v, hi_v = self.speed_range_mps
        return bool(np.any(inside & along & (v_along >= lo_v) & (v_along < hi_v)))


def _side_name(road_map: RoadMap, crosswalk: Crosswalk, entry: np.ndarray) -> str:
    """Side of a crosswalk entry (2,) [m]: "right" / "left" of the nearest lane's traffic.

    Empty without lanes (the caller then names the ends "a" / "b" by walking direction).
    """
    if not road_map.lanes:
        return ""
    best = None
    for lane in road_map.lanes:
        route = Route(lane.centerline)
        _, lateral, heading = route.project(crosswalk.center)
        if best is None or abs(float(lateral)) < best[0]:
            best = (abs(float(lateral)), float(heading))
    heading = best[1]
    rel = entry - crosswalk.center
    cross = math.cos(heading) * rel[1] - math.sin(heading) * rel[0]
    return "left" if cross > 0 else "right"


def crosswalk_hypotheses(road_map: RoadMap, walk_speeds_mps=(1.3,), curb_offset_m: float = 1.0,
                         progress_step_m: float | None = None) -> list[Hypothesis]:
    """"none" plus, per curb end of every crosswalk, one hypothesis per (progress, speed) bin.

    The path starts at the crosswalk's end (curb) moved curb_offset_m onto the sidewalk and
    ends at the far entry (a straight 2-point path). <side> is "right"/"left" of the traffic
    direction of the nearest lane. Progress bins are 0, progress_step_m, 2 progress_step_m,
    ... while on the road (the last one starts at least one bin before the far curb); None:
    only the curb entry (the paper's "steps off the curb now").

    Args:
        road_map: the static map (its crosswalks and lanes).
        walk_speeds_mps: the speed bins [m/s] (a float: one bin).
        curb_offset_m: how far from the curb a hypothesised pedestrian starts [m].
        progress_step_m: length of a progress bin [m], or None.

    Returns:
        The L hypotheses, "none" first, then by crosswalk, end, progress bin, speed bin.
    """
    speeds = np.atleast_1d(np.asarray(walk_speeds_mps, dtype=np.float64))
    hyps = [Hypothesis("none", False)]
    many = len(road_map.crosswalks) > 1
    for i, cw in enumerate(road_map.crosswalks):
        d = np.array([math.cos(cw.walk_heading_rad), math.sin(cw.walk_heading_rad)])
        length = cw.length_m + 2.0 * curb_offset_m
        if progress_step_m is None:
            progress = np.zeros(1)
            step = length
        else:
            step = float(progress_step_m)
            progress = np.arange(0.0, cw.length_m + curb_offset_m - step + 1e-9, step)
        ends = [(cw.center - d * (0.5 * cw.length_m + curb_offset_m), d),
                (cw.center + d * (0.5 * cw.length_m + curb_offset_m), -d)]
        for k, (entry, walk_dir) in enumerate(ends):
            side = _side_name(road_map, cw, entry) or "ab"[k]
            path = f"crossing{i}_{side}" if many else f"crossing_{side}"
            for j, p in enumerate(progress):
                for m, speed in enumerate(speeds):
                    name = path if len(progress) * len(speeds) == 1 else f"{path}_p{j}_v{m}"
                    hyps.append(Hypothesis(
                        name, True, entry, walk_dir, float(speed), walk_length_m=length,
                        curb_offset_m=curb_offset_m, half_width_m=0.5 * cw.width_m,
                        crosswalk_index=i, kind="pedestrian", path=path, progress_m=float(p),
                        progress_bin=j, speed_bin=m, bin_length_m=step,
                    ))
    return hyps


def hypothesis_objects(hypotheses: list[Hypothesis], times_s) -> tuple:
    """Each hypothesis' hidden agent at future times, as one extra object per scene.

    Args:
        hypotheses: the L hypotheses.
        times_s: (T,) prediction times [s].

    Returns:
        The arguments of models.scene_prediction.ScenePrediction.with_extra: xy (L, T, 2) [m],
        heading (L, T) [rad], length (L,) [m], width (L,) [m], is_pedestrian (L,) bool (a
        hypothesised vehicle is a vehicle), mask (L,) bool (False for "none").
    """
    times = np.asarray(times_s, dtype=np.float64)
    n, n_t = len(hypotheses), len(times)
    xy = np.zeros((n, n_t, 2))
    heading = np.zeros((n, n_t))
    length = np.full(n, PEDESTRIAN_DIAMETER_M)
    width = np.full(n, PEDESTRIAN_DIAMETER_M)
    is_pedestrian = np.ones(n, dtype=bool)
    for i, h in enumerate(hypotheses):
        if h.present:
            xy[i] = h.predict_xy(times)
            heading[i] = h.predict_heading(times)
            length[i], width[i] = h.length_m, h.width_m
            is_pedestrian[i] = h.kind == "pedestrian"
    present = np.array([h.present for h in hypotheses], dtype=bool)
    return xy, heading, length, width, is_pedestrian, present


def _event_probabilities(hypotheses: list[Hypothesis], dt_s: float,
                         hazard_per_s: float | Mapping) -> dict:
    """{kind: probability of an arrival (and of a vanishing) per step} of the kinds present."""
    kinds = {h.kind for h in hypotheses if h.present}
    if isinstance(hazard_per_s, Mapping):
        missing = kinds - set(hazard_per_s)
        if missing:
            raise ValueError(f"motion_transition: hazard_per_s has no rate for {sorted(missing)}")
        rates = {k: float(hazard_per_s[k]) for k in kinds}
    else:
        rates = dict.fromkeys(kinds, float(hazard_per_s))
    return {k: float(np.clip(r * dt_s, 0.0, 1.0)) for k, r in rates.items()}


def motion_transition(hypotheses: list[Hypothesis], dt_s: float,
                      hazard_per_s: float | Mapping) -> np.ndarray:
    """(L, L) column-stochastic motion model of the hypotheses over one step of dt_s [s].

    A present hypothesis moves to the next progress bin of its path and speed with
    probability min(speed * dt / bin length, 1) (after the last bin: to "none"), and vanishes
    to "none" with probability hazard * dt of its kind; "none" sends hazard * dt of each kind
    to that kind's entry bins (progress bin 0), evenly. Without "none" (index 0 must be it) or
    without present hypotheses: the identity.

    Args:
        hypotheses: the L hypotheses, "none" first.
        dt_s: step length [s].
        hazard_per_s: arrival and vanishing rate [1/s], one for all kinds or {kind: rate}.
    """
    n = len(hypotheses)
    mat = np.eye(n)
    if n <= 1 or hypotheses[0].present:
        return mat
    p_event = _event_probabilities(hypotheses, dt_s, hazard_per_s)
    index = {(h.path, h.progress_bin, h.speed_bin): i for i, h in enumerate(hypotheses)}
    mat[0, 0] = 1.0 - min(sum(p_event.values()), 1.0)
    for kind, p in p_event.items():
        entries = [i for i, h in enumerate(hypotheses)
                   if h.present and h.kind == kind and h.progress_bin == 0]
        for i in entries:
            mat[i, 0] = p / len(entries)
    for i, h in enumerate(hypotheses):
        if not h.present:
            continue
        p = p_event[h.kind]
        advance = min(h.walk_speed_mps * dt_s / h.bin_length_m, 1.0) if h.bin_length_m else 0.0
        nxt = index.get((h.path, h.progress_bin + 1, h.speed_bin), 0)
        if h.kind == "pedestrian" and h.bin_length_m >= h.walk_length_m:
            # the paper's single "steps off now" pattern
            advance = 0.0
        mat[:, i] = 0.0
        mat[i, i] = (1.0 - p) * (1.0 - advance)
        mat[nxt, i] += (1.0 - p) * advance
        mat[0, i] += p
    return mat


def stationary_distribution(transition: np.ndarray, n_steps: int = 2000) -> np.ndarray:
    """(L,) the long-run distribution of a column-stochastic transition (power iteration).

    Every robot's belief starts from it, and the iteration (n_steps / 2 products with the
    squared matrix) takes 1-2 ms: the result is kept per transition (its bytes), so a study's
    episodes after the first pay nothing. A new array each call (the caller may change it).

    Args:
        transition: (L, L) column-stochastic matrix.
        n_steps: iterations, from the uniform distribution.
    """
    arr = np.asarray(transition)
    return _stationary(arr.tobytes(), arr.shape, arr.dtype.str, int(n_steps)).copy()


@functools.lru_cache(maxsize=64)
def _stationary(data: bytes, shape: tuple, dtype: str, n_steps: int) -> np.ndarray:
    """stationary_distribution of the matrix held in `data` (C order, `shape`, `dtype`)."""
    transition = np.frombuffer(data, dtype=dtype).reshape(shape)
    n = len(transition)
    p = np.full(n, 1.0 / max(n, 1))
    power = np.linalg.matrix_power(transition, 2)
    for _ in range(n_steps // 2):
        p = power @ p
    return p / p.sum()
