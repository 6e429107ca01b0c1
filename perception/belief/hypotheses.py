"""Hypotheses over hidden pedestrians: motion patterns at the map's crosswalks (section III-B-2).

The hidden physical states x_l, l = 1..L, are represented by motion patterns (`Hypothesis`):
"none" (no pedestrian about to cross) and, for each curb end of each crosswalk, "a pedestrian
steps off that curb now and walks across" at a fixed walking speed, stopping at the far end.
Each present hypothesis has a region, (K, 2) sample points [m] of where its pedestrian would be
now or soon, which the robot's depth rays can show empty (negative information, own_sensors.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marl_social.sim.road_map import Crosswalk, RoadMap, Route

PEDESTRIAN_DIAMETER_M = 0.6  # footprint of a hypothesised pedestrian [m]
REGION_ALONG_M = (-0.5, 1.0)  # region: from 0.5 m behind the entry to 1 m past the curb [m]
REGION_EDGE_M = 0.5  # region points stay this far inside the crosswalk's side edges [m]
REGION_N_ALONG = 5  # region sample points along the walking direction
REGION_N_ACROSS = 3  # region sample points across it


@dataclass(frozen=True, eq=False)
class Hypothesis:
    """A representative motion pattern of a possibly hidden pedestrian.

    Attributes:
        name: "none", "crossing_right", "crossing_left", ... (with several crosswalks
            "crossing<i>_<side>").
        present: False only for "none".
        start_xy: (2,) where it stands on the curb at the crosswalk entry [m].
        walk_dir: (2,) unit vector across the road.
        walk_speed_mps: walking speed [m/s].
        walk_length_m: distance from start_xy to the far entry, where it stops [m].
        curb_offset_m: distance from start_xy to the curb (the crosswalk's end) [m].
        half_width_m: half the crosswalk's extent along the road [m].
        crosswalk_index: index into RoadMap.crosswalks (-1 for "none").
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

    def predict_xy(self, times_s) -> np.ndarray:
        """Positions (T, 2) [m] at future times (T,) [s].

        The pedestrian is at the curb entry now, walks across at walk_speed_mps and stops at
        the far entry. Raises ValueError for the "none" hypothesis.
        """
        if not self.present:
            raise ValueError(f"hypothesis {self.name!r} has no pedestrian to predict")
        t = np.asarray(times_s, dtype=np.float64)
        dist = np.clip(self.walk_speed_mps * t, 0.0, self.walk_length_m)
        return self.start_xy + dist[:, None] * self.walk_dir

    def region(self) -> np.ndarray:
        """(K, 2) sample points [m] of where the pedestrian would be now or soon.

        The curb entry area and the first metre of road (REGION_N_ALONG along x
        REGION_N_ACROSS across). Empty (0, 2) for "none".
        """
        if not self.present:
            return np.zeros((0, 2))
        along = np.linspace(REGION_ALONG_M[0], self.curb_offset_m + REGION_ALONG_M[1],
                            REGION_N_ALONG)
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


def crosswalk_hypotheses(road_map: RoadMap, walk_speed_mps: float = 1.3,
                         curb_offset_m: float = 1.0) -> list[Hypothesis]:
    """"none" plus one "crossing_<side>" per curb end of every crosswalk.

    The entry point is the crosswalk's end (curb) moved curb_offset_m onto the sidewalk; the
    pedestrian walks from there towards the other end and stops at the far entry. <side> is
    "right"/"left" of the traffic direction of the nearest lane.

    Args:
        road_map: the static map (its crosswalks and lanes).
        walk_speed_mps: walking speed of every hypothesised pedestrian [m/s].
        curb_offset_m: how far from the curb a hypothesised pedestrian starts [m].

    Returns:
        The L hypotheses, "none" first.
    """
    hyps = [Hypothesis("none", False)]
    many = len(road_map.crosswalks) > 1
    for i, cw in enumerate(road_map.crosswalks):
        d = np.array([math.cos(cw.walk_heading_rad), math.sin(cw.walk_heading_rad)])
        ends = [(cw.center - d * (0.5 * cw.length_m + curb_offset_m), d),
                (cw.center + d * (0.5 * cw.length_m + curb_offset_m), -d)]
        for k, (entry, walk_dir) in enumerate(ends):
            side = _side_name(road_map, cw, entry) or "ab"[k]
            name = f"crossing{i}_{side}" if many else f"crossing_{side}"
            hyps.append(Hypothesis(
                name, True, entry, walk_dir, float(walk_speed_mps),
                walk_length_m=cw.length_m + 2.0 * curb_offset_m, curb_offset_m=curb_offset_m,
                half_width_m=0.5 * cw.width_m, crosswalk_index=i,
            ))
    return hyps
