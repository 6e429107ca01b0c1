"""Hypotheses over hidden agents: (kind, path, progress bin, speed bin) with a motion model.

The hidden physical states x_l, l = 1..L (section III-B-2) are "none" (no hidden agent) and,
for every path a hidden agent may take, one hypothesis per (progress bin, speed bin): "an
agent of this kind is `progress_m` along this path now and moves at `speed_mps`". Today's
paths are the two walking directions of every crosswalk (kind "pedestrian", from the curb
entry to the far entry); a vehicle on a lane the robot cannot see is the same structure with
kind "vehicle" and a lane as its path.

Progress bin 0 is the curb entry (the paper's "steps off the curb now"); the others are
already on the road, so that a pedestrian out there has a state that keeps walking.
`motion_transition` is the motion model: each step a hypothesis' mass moves to the next
progress bin with probability speed * dt / bin length (the expected progress is the speed),
leaves for "none" after the last bin (it has crossed), new agents arrive at the entry bins
(`hazard_per_s`) and hypothesised agents vanish at the same rate (beliefs never lock).

Each present hypothesis has a region, (K, 2) sample points [m] of where its agent is now,
which the robot's depth rays can show empty (negative information), and `matches`, whether a
seen object is its agent (positive information; own_sensors.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marl_social.sim.road_map import Crosswalk, RoadMap, Route

PEDESTRIAN_DIAMETER_M = 0.6  # footprint of a hypothesised pedestrian [m]
REGION_BEHIND_M = 0.5  # a region starts this far behind its agent's progress [m]
REGION_AHEAD_ENTRY_M = 1.0  # the entry bin's region reaches this far past the curb [m]
REGION_EDGE_M = 0.5  # region points stay this far inside the crosswalk's side edges [m]
REGION_N_ALONG = 5  # region sample points along the path
REGION_N_ACROSS = 3  # region sample points across it
MATCH_MARGIN_M = 1.0  # a detection this far outside a hypothesis' region can match it [m]


@dataclass(frozen=True, eq=False)
class Hypothesis:
    """A hidden agent on a path at a progress and speed bin (or "none").

    Attributes:
        name: "none", or "<path>_p<progress bin>_v<speed bin>"; with one bin of each the
            path's name alone ("crossing_right", "crossing_left", "crossing<i>_<side>").
        present: False only for "none".
        kind: "pedestrian" ("vehicle" for hidden cars), "" for "none".
        path: the path's name ("crossing_right"; the hypothesis' group), "" for "none".
        start_xy: (2,) the path's start: the curb entry of a crosswalk [m].
        walk_dir: (2,) unit vector of the path (across the road).
        walk_speed_mps: the speed bin's speed [m/s].
        walk_length_m: from start_xy to the far entry, where the agent stops [m].
        curb_offset_m: from start_xy to the curb (the crosswalk's end) [m].
        half_width_m: half the crosswalk's extent along the road [m].
        crosswalk_index: index into RoadMap.crosswalks (-1 for "none").
        progress_m: where along the path the agent is now [m].
        progress_bin: index of the progress bin (0: the curb entry).
        speed_bin: index of the speed bin.
        bin_length_m: length of a progress bin [m] (the motion model's step).
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

    def predict_xy(self, times_s) -> np.ndarray:
        """Positions (T, 2) [m] at future times (T,) [s].

        The agent moves on from progress_m at walk_speed_mps and stops at the path's end.
        Raises ValueError for the "none" hypothesis.
        """
        if not self.present:
            raise ValueError(f"hypothesis {self.name!r} has no agent to predict")
        t = np.asarray(times_s, dtype=np.float64)
        dist = np.clip(self.progress_m + self.walk_speed_mps * t, 0.0, self.walk_length_m)
        return self.start_xy + dist[:, None] * self.walk_dir

    def _along_range(self) -> tuple[float, float]:
        """Where along the path [m] the agent of this hypothesis is now."""
        if self.progress_bin == 0:
            return self.progress_m - REGION_BEHIND_M, self.curb_offset_m + REGION_AHEAD_ENTRY_M
        return self.progress_m - REGION_BEHIND_M, self.progress_m + self.bin_length_m

    def region(self) -> np.ndarray:
        """(K, 2) sample points [m] of where the agent is now.

        REGION_N_ALONG x REGION_N_ACROSS points over the progress bin (the entry bin: the curb
        entry area and the first metre of road). Empty (0, 2) for "none".
        """
        if not self.present:
            return np.zeros((0, 2))
        lo, hi = self._along_range()
        along = np.linspace(lo, hi, REGION_N_ALONG)
        half = max(self.half_width_m - REGION_EDGE_M, 0.0)
        across = np.linspace(-half, half, REGION_N_ACROSS)
        normal = np.array([-self.walk_dir[1], self.walk_dir[0]])
        pts = (self.start_xy + along[:, None, None] * self.walk_dir
               + across[None, :, None] * normal)
        return pts.reshape(-1, 2)

    def corridor_coords(self, xy) -> tuple[np.ndarray, np.ndarray]:
        """Coordinates of points (n, 2) [m] in this hypothesis' frame.

        Returns `along` from start_xy in walk_dir and `across` (left of walk_dir) [m], each (n,).
        """
        rel = np.asarray(xy, dtype=np.float64) - self.start_xy
        along = rel @ self.walk_dir
        across = rel @ np.array([-self.walk_dir[1], self.walk_dir[0]])
        return along, across

    def matches(self, xy, velocity, walking_speed_min_mps: float) -> bool:
        """Whether one of the seen pedestrians (n, 2) [m], (n, 2) [m/s] is this agent.

        It must be in the bin's region (+- MATCH_MARGIN_M) and either on the road not walking
        against the path, or walking along it at >= walking_speed_min_mps; a pedestrian
        standing on the sidewalk matches nothing.
        """
        if not self.present or len(xy) == 0:
            return False
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
    ends at the far entry. <side> is "right"/"left" of the traffic direction of the nearest
    lane. Progress bins are 0, progress_step_m, 2 progress_step_m, ... while on the road (the
    last one starts at least one bin before the far curb); None: only the curb entry (the
    paper's "steps off the curb now").

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


def motion_transition(hypotheses: list[Hypothesis], dt_s: float,
                      hazard_per_s: float) -> np.ndarray:
    """(L, L) column-stochastic motion model of the hypotheses over one step of dt_s [s].

    A present hypothesis moves to the next progress bin of its path and speed with
    probability min(speed * dt / bin length, 1) (after the last bin: to "none"), and vanishes
    to "none" with probability hazard_per_s * dt; "none" sends hazard_per_s * dt to the entry
    bins (progress bin 0), evenly. Without "none" (index 0 must be it) or without present
    hypotheses: the identity.

    Args:
        hypotheses: the L hypotheses, "none" first.
        dt_s: step length [s].
        hazard_per_s: arrival and vanishing rate [1/s].
    """
    n = len(hypotheses)
    mat = np.eye(n)
    if n <= 1 or hypotheses[0].present:
        return mat
    p_event = float(np.clip(hazard_per_s * dt_s, 0.0, 1.0))
    index = {(h.path, h.progress_bin, h.speed_bin): i for i, h in enumerate(hypotheses)}
    entries = [i for i, h in enumerate(hypotheses) if h.present and h.progress_bin == 0]
    mat[0, 0] = 1.0 - p_event
    for i in entries:
        mat[i, 0] = p_event / len(entries)
    for i, h in enumerate(hypotheses):
        if not h.present:
            continue
        advance = min(h.walk_speed_mps * dt_s / h.bin_length_m, 1.0) if h.bin_length_m else 0.0
        nxt = index.get((h.path, h.progress_bin + 1, h.speed_bin), 0)
        if h.bin_length_m >= h.walk_length_m:  # the paper's single "steps off now" pattern
            advance = 0.0
        mat[:, i] = 0.0
        mat[i, i] = (1.0 - p_event) * (1.0 - advance)
        mat[nxt, i] += (1.0 - p_event) * advance
        mat[0, i] += p_event
    return mat


def stationary_distribution(transition: np.ndarray, n_steps: int = 2000) -> np.ndarray:
    """(L,) the long-run distribution of a column-stochastic transition (power iteration).

    Args:
        transition: (L, L) column-stochastic matrix.
        n_steps: iterations, from the uniform distribution.
    """
    n = len(transition)
    p = np.full(n, 1.0 / max(n, 1))
    power = np.linalg.matrix_power(transition, 2)
    for _ in range(n_steps // 2):
        p = power @ p
    return p / p.sum()
