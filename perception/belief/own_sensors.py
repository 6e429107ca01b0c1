"""The robot's own sensors as evidence about hidden agents (Algorithm 1, step 2).

A pedestrian the robot sees crossing (or stepping onto) a crosswalk, or a vehicle it sees
driving along a lane with the right of way towards the robot's route, is positive information
for the matching hypotheses (p_detect against p_false_alarm; `Hypothesis.matches`). Otherwise
the part of each hypothesis' region that the robot's depth rays show empty is negative
information:

    P(no detection | l) = (1 - p_false_alarm) (1 - p_detect * visible_fraction_l)
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.perception.belief import compiled
from marl_social.perception.belief.config import BeliefConfig
from marl_social.perception.belief.hypotheses import (
    MATCH_MARGIN_M,
    PEDESTRIAN_DIAMETER_M,
    VEHICLE_MATCH_HEADING_RAD,
    Hypothesis,
)
from marl_social.perception.fov import depth_ray_angles
from marl_social.perception.tracking import TrackSet
from marl_social.sim.observation import EGO_INDEX, DecodedObservation

PROBABILITY_MIN = 1e-12  # probabilities are clipped to [this, 1 - this] before the log
CONE_TOLERANCE_RAD = 1e-9  # a region point on the edge of the sensor cone is inside it [rad]
# the ego fields visible_fraction reads: position [m], heading's cos and sin, sensor range [m]
# and half-angle [rad]
_EGO_VIEW = [EGO_INDEX[k] for k in ("x", "y", "cos_psi", "sin_psi", "sensor_range",
                                    "sensor_half_angle")]


class OwnSensors:
    """Likelihood of the robot's own detections and free space under each hypothesis.

    Args:
        hypotheses: the L hypotheses ("none" first).
        config: BeliefConfig (p_detect, p_false_alarm, walking_speed_min_mps).
    """

    def __init__(self, hypotheses: list[Hypothesis], config: BeliefConfig):
        """Cache the present hypotheses' regions (P, K, 2) [m]."""
        self.hypotheses = hypotheses
        self.config = config
        self._present = np.array([h.present for h in hypotheses])
        self._present_idx = np.flatnonzero(self._present)
        self._has_vehicles = any(h.kind == "vehicle" for h in hypotheses)
        regions = [h.region() for h in hypotheses if h.present]
        self._region = np.array(regions) if regions else np.zeros((0, 1, 2))  # (P, K, 2)
        self._region_x = np.ascontiguousarray(self._region[..., 0])  # (P, K) [m]
        self._region_y = np.ascontiguousarray(self._region[..., 1])
        p_fa = min(max(config.p_false_alarm, PROBABILITY_MIN), 1.0 - PROBABILITY_MIN)
        self._p_false_alarm = p_fa
        self._no_detection_lik = 1.0 - p_fa  # P(no false alarm)
        self._ray_cache: tuple | None = None
        self._paths = _path_groups(hypotheses)

    def visible_fraction(self, decoded: DecodedObservation) -> np.ndarray:
        """(L,) fraction of each hypothesis' region the robot's depth rays show free.

        0 for "none". A point is visible if within range and cone and the depth along its
        bearing (the shorter of the two neighbouring rays) reaches it, less a pedestrian's
        radius.

        Args:
            decoded: the robot's decoded observation (ego block and depth rays).
        """
        depth = decoded.depth_m
        out = np.zeros(len(self.hypotheses))
        if len(self._present_idx) == 0 or len(depth) == 0:
            return out
        depth = depth.astype(np.float64)
        ego = decoded.ego.tolist()  # float32 -> Python floats (a list: cheaper than indexing)
        x, y, c, s, rng, half = [ego[i] for i in _EGO_VIEW]
        angles = self._ray_angles(half, len(depth))
        rel_x, rel_y = self._region_x - x, self._region_y - y  # (P, K)
        # np.hypot and np.arctan2 in numpy, the wrapping, the rays' lookup and the count
        # compiled (view_kernels.visible_counts: the same arithmetic)
        counts = compiled.view().visible_counts(
            np.hypot(rel_x, rel_y), np.arctan2(rel_y, rel_x), math.atan2(s, c), angles, depth,
            (rng, half, CONE_TOLERANCE_RAD, 0.5 * PEDESTRIAN_DIAMETER_M))
        # the mean of each row's K booleans: an exact count over K, divided as np.mean divides
        out[self._present_idx] = counts / self._region_x.shape[1]
        return out

    def _ray_angles(self, half: float, n_rays: int) -> np.ndarray:
        """The robot's depth-ray directions (n_rays,) [rad], cached per (half-angle, n_rays)."""
        key = (half, n_rays)
        if self._ray_cache is None or self._ray_cache[0] != key:
            angles = depth_ray_angles(np.array([half]), n_rays)[0]
            self._ray_cache = (key, np.ascontiguousarray(angles, dtype=np.float64))
        return self._ray_cache[1]

    def _match(self, kind: str, xy, velocity) -> np.ndarray:
        """(L,) bool: the hypotheses of one kind that one of the seen agents matches.

        `Hypothesis.matches` of every hypothesis, the coordinates computed once per path
        (`_PathGroup`).
        """
        out = np.zeros(len(self.hypotheses), dtype=bool)
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        vel = np.asarray(velocity, dtype=np.float64).reshape(-1, 2)
        if len(xy) == 0:
            return out
        v_min = self.config.walking_speed_min_mps
        for group in self._paths:
            if group.kind == kind:
                out[group.index] = group.matches(xy, vel, v_min)
        return out

    def match_pedestrians(self, xy, velocity) -> np.ndarray:
        """(L,) bool: pedestrian hypotheses consistent with the pedestrians the robot sees.

        `Hypothesis.matches`: a seen pedestrian in a hypothesis' region (+- a margin), on the
        road not walking against its direction, or walking in its direction at >=
        walking_speed_min_mps. A pedestrian standing on the sidewalk matches nothing.

        Args:
            xy: (n, 2) seen pedestrians' positions [m].
            velocity: (n, 2) their velocities [m/s].
        """
        return self._match("pedestrian", xy, velocity)

    def match_vehicles(self, xy, velocity) -> np.ndarray:
        """(L,) bool: vehicle hypotheses consistent with the vehicles the robot sees.

        `Hypothesis.matches`: a seen vehicle on the hypothesis' lane within its bin's footprint
        (+- a margin), heading along the lane at a speed in the hypothesis' speed bin. A car
        standing in the lane, or driving against it, matches nothing.

        Args:
            xy: (n, 2) seen vehicles' positions [m].
            velocity: (n, 2) their velocities [m/s].
        """
        return self._match("vehicle", xy, velocity)

    def log_likelihood(self, decoded: DecodedObservation, tracks: TrackSet):
        """Positive and negative information from the robot's own sensors.

        Args:
            decoded: the robot's decoded observation.
            tracks: the robot's current tracks.

        Returns:
            (L,) log-likelihood, (L,) visible fraction, (L,) bool matched detections.
        """
        p_detect = self.config.p_detect
        detected = np.zeros(len(self.hypotheses), dtype=bool)
        if len(tracks):
            seen_ped = tracks.is_pedestrian & tracks.seen
            if seen_ped.any():
                detected = self.match_pedestrians(tracks.xy[seen_ped], tracks.velocity[seen_ped])
            if self._has_vehicles:
                seen_veh = tracks.seen & ~tracks.is_pedestrian
                if seen_veh.any():
                    detected |= self.match_vehicles(tracks.xy[seen_veh],
                                                    tracks.velocity[seen_veh])
        visible = self.visible_fraction(decoded)
        # a detection is explained by a matching hypothesis, or is a false alarm (then any
        # other hidden agent's region was missed); without one every region was missed
        lik = compiled.view().own_likelihoods(visible, self._present, detected, p_detect,
                                                 self._p_false_alarm, self._no_detection_lik,
                                                 PROBABILITY_MIN)
        with np.errstate(divide="ignore"):
            return np.log(lik), visible, detected


class _PathGroup:
    """The present hypotheses of one path (same kind and geometry), for `OwnSensors._match`.

    `Hypothesis.matches` for all of them at once: the seen agents' coordinates along the path
    computed once (by the first hypothesis, the same arithmetic), the bins' bounds compared in
    one broadcast.

    Args:
        hypotheses: the group's hypotheses (one path).
        index: (H,) their indices in the hypothesis list.
    """

    def __init__(self, hypotheses: list[Hypothesis], index: np.ndarray):
        """Tabulate each hypothesis' bounds (H, 1) as `Hypothesis.matches` computes them."""
        self.first = hypotheses[0]
        self.kind = self.first.kind
        self.index = index
        bounds = []
        for h in hypotheses:
            lo, hi = h._along_range()
            if self.kind == "vehicle":
                bounds.append((h.half_width_m + MATCH_MARGIN_M, lo - MATCH_MARGIN_M,
                               hi + MATCH_MARGIN_M, *h.speed_range_mps))
            else:
                road_end = h.walk_length_m - h.curb_offset_m
                bounds.append((h.half_width_m + MATCH_MARGIN_M, lo - MATCH_MARGIN_M,
                               min(hi + MATCH_MARGIN_M, road_end), h.curb_offset_m, road_end))
        self.bounds = np.array(bounds, dtype=np.float64).T[..., None]  # (B, H, 1)
        self._bounds = np.ascontiguousarray(self.bounds[..., 0])  # (B, H), for the kernel
        route = self.first._route
        # a vehicle path's segments for view_kernels.route_projections (paths.LanePaths')
        self._route_heading = route.segment_heading_rad if route is not None else None
        self._segments = None if route is None else np.column_stack(
            [route.segment_start_m, route.segment_direction, route.segment_length_m,
             route.vertex_s_m[:-1]])

    def _path_coords(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`Hypothesis.path_coords` of the first hypothesis: s, lateral [m], heading [rad] (n,).

        Compiled for finite points (view_kernels.route_projections, Route.project's
        arithmetic), else Route.project itself.
        """
        if self._segments is None or not np.isfinite(xy).all():
            return self.first.path_coords(xy)
        s, lateral, k = compiled.view().route_projections(
            np.ascontiguousarray(xy, dtype=np.float64), self._segments)
        return s, lateral, self._route_heading[k]

    def matches(self, xy: np.ndarray, velocity: np.ndarray, walking_speed_min_mps: float
                ) -> np.ndarray:
        """(H,) bool: whether one of the seen agents (n, 2) [m], (n, 2) [m/s] is each one's agent.

        Args:
            xy: (n, 2) seen agents' positions [m], n >= 1.
            velocity: (n, 2) their velocities [m/s].
            walking_speed_min_mps: pedestrians only.
        """
        # the coordinates and speeds in numpy, the bins' comparisons compiled
        # (view_kernels.path_matches)
        if self.kind == "vehicle":
            s, lateral, heading = self._path_coords(xy)
            speed = np.hypot(velocity[:, 0], velocity[:, 1])
            v_along = velocity[:, 0] * np.cos(heading) + velocity[:, 1] * np.sin(heading)
            return compiled.view().path_matches(
                _f8(s), _f8(lateral), _f8(v_along),
                _f8(speed * math.cos(VEHICLE_MATCH_HEADING_RAD)), self._bounds,
                float(walking_speed_min_mps), True)
        along, across = self.first.corridor_coords(xy)
        v_along = _f8(velocity @ self.first.walk_dir)
        return compiled.view().path_matches(_f8(along), _f8(across), v_along, v_along,
                                               self._bounds, float(walking_speed_min_mps),
                                               False)


def _f8(values) -> np.ndarray:
    """Values (n,) as a C-contiguous float64 array (the kernels' input; no copy if it is)."""
    return np.ascontiguousarray(values, dtype=np.float64)


def _path_groups(hypotheses: list[Hypothesis]) -> list[_PathGroup]:
    """The present hypotheses grouped by path: same kind, start, direction and polyline."""
    groups: dict[tuple, list[int]] = {}
    for i, h in enumerate(hypotheses):
        if h.present:
            key = (h.kind, h.path, np.asarray(h.start_xy, dtype=np.float64).tobytes(),
                   np.asarray(h.walk_dir, dtype=np.float64).tobytes(),
                   np.asarray(h.path_xy, dtype=np.float64).tobytes(),
                   np.asarray(h.path_xy).shape)
            groups.setdefault(key, []).append(i)
    return [_PathGroup([hypotheses[i] for i in index], np.array(index))
            for index in groups.values()]
