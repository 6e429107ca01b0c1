"""What a driver expects of a vehicle that must give way: it stops before the zone if it can.

A driver predicts the others at constant velocity (agents/base.py), except a vehicle that must
give way in a conflict zone ahead of it. A tracked vehicle yields in a zone of the static map
when it does not travel along one of the zone's priority lanes (sim/route_rules.py, the rule
the drivers themselves follow). If such a vehicle, outside the zone, is heading into it (its
footprint's path along its velocity meets the zone) and can stop before the zone at no more
than COMFORTABLE_DECEL_MPS2 (sim/signal_rules.py, the same comfort a driver accepts to stop on
yellow), the driver expects it to do so: uniform deceleration a = v^2 / (2 d) until it rests
with its front d metres on, at the zone's edge. One that would need harder braking, or whose
front is already in the zone, is predicted at constant velocity: it is taken to be going.

This is the road's rule as every driver knows it from the map: a car that crept past its stop
line at walking pace is not expected to pull into the main road's lane a metre ahead of it
(humans with the right of way do not brake hard for it), while one that drives at the lane too
fast to stop comfortably is. Pedestrians and vehicles at rest (<= MOVING_SPEED_MPS) keep the
constant-velocity prediction. A map without conflict zones changes nothing.

It is the humans' option, off by default: a human driver predicts through
`YieldExpectation.predict_xy` when its planner parameter `expects_yield` is set
(agents/human.py; the intersection scenarios' knob `human_expects_yield`), and the robot's
model of the humans when BeliefConfig.human_expects_yield is (perception/belief/
human_scene.py; the robot's planner parameter `human_expects_yield`, set by the same knob).
What it changes at the intersections: docs/scenarios.md, docs/studies/yield-expectation.md.
"""

from __future__ import annotations

import numpy as np

from marl_social.sim.road_map import RoadMap
from marl_social.sim.route_rules import priority_mask
from marl_social.sim.signal_rules import COMFORTABLE_DECEL_MPS2

MOVING_SPEED_MPS = 0.1  # at or below this speed a vehicle is taken to be at rest [m/s]


class YieldExpectation:
    """The static map's conflict zones as a driver uses them to predict who gives way.

    Args:
        road_map: the static map (its conflict zones and lanes).
        decel_mps2: the deceleration up to which a yielding vehicle is expected to stop
            [m/s^2], > 0 (default COMFORTABLE_DECEL_MPS2).
    """

    def __init__(self, road_map: RoadMap, decel_mps2: float = COMFORTABLE_DECEL_MPS2):
        if not decel_mps2 > 0:
            raise ValueError(f"YieldExpectation: decel_mps2 must be > 0, got {decel_mps2}")
        self.road_map = road_map
        self.decel_mps2 = float(decel_mps2)
        # per zone: (V, 2) vertices, (V, 2) outward unit normals of the edges from them
        self._zones = []
        for zone in road_map.conflict_zones:
            vertices = np.asarray(zone.polygon, dtype=np.float64)  # counter-clockwise
            edge = np.roll(vertices, -1, axis=0) - vertices
            normal = np.stack([edge[:, 1], -edge[:, 0]], axis=1)
            normal /= np.linalg.norm(normal, axis=1, keepdims=True)
            self._zones.append((zone, vertices, normal))

    @property
    def applies(self) -> bool:
        """Whether the map has a conflict zone (else predict_xy is the constant velocity)."""
        return bool(self._zones)

    def stop_distance_m(self, xy, velocity, heading_rad, length_m, width_m,
                        is_pedestrian) -> np.ndarray:
        """(M,) how far each object's front is from the nearest zone it must yield in [m].

        The distance along its velocity from its front to the zone's edge (the first of three
        rays, from its centre line and its two sides, to meet the zone); inf where it heads
        into no such zone, is a pedestrian, is at rest, or its front is already in the zone
        (it is committed).

        Args:
            xy: (M, 2) centres [m].
            velocity: (M, 2) velocities [m/s].
            heading_rad: (M,) headings [rad] (which lanes they travel along).
            length_m: (M,) footprint lengths [m].
            width_m: (M,) footprint widths [m].
            is_pedestrian: (M,) bool.
        """
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        velocity = np.asarray(velocity, dtype=np.float64).reshape(-1, 2)
        speed = np.hypot(velocity[:, 0], velocity[:, 1])
        out = np.full(len(xy), np.inf)
        moving = (speed > MOVING_SPEED_MPS) & ~np.asarray(is_pedestrian, dtype=bool)
        if not moving.any():
            return out
        direction = velocity / np.where(moving, speed, 1.0)[:, None]
        # three rays along the velocity: from the centre and from half the width to each side
        side = 0.5 * np.asarray(width_m, dtype=np.float64)[:, None] * np.stack(
            [-direction[:, 1], direction[:, 0]], axis=1)  # (M, 2) [m]
        origins = np.stack([xy, xy + side, xy - side], axis=1)  # (M, 3, 2)
        half_length = 0.5 * np.asarray(length_m, dtype=np.float64)
        for zone, vertices, normal in self._zones:
            yields = moving & ~priority_mask(zone, self.road_map, xy, heading_rad)
            if not yields.any():
                continue
            # Cyrus-Beck: the ray origin + u * direction is inside edge k where
            # offset_k + u * rate_k <= 0; offset (M, 3, V), rate (M, 1, V)
            offset = ((origins[:, :, None, :] - vertices) * normal).sum(-1)
            rate = (direction @ normal.T)[:, None, :]
            with np.errstate(divide="ignore", invalid="ignore"):
                bound = -offset / rate
            enter = np.where(rate < 0, bound, -np.inf).max(axis=2)  # (M, 3)
            leave = np.where(rate > 0, bound, np.inf).min(axis=2)
            misses = ((rate == 0) & (offset > 0)).any(axis=2) | (enter > leave) | (leave <= 0)
            enter = np.where(misses, np.inf, enter).min(axis=1)  # (M,) the first ray in
            front_gap = enter - half_length
            # a front already in the zone is committed
            hits = yields & np.isfinite(front_gap) & (front_gap > 0)
            out = np.where(hits, np.minimum(out, front_gap), out)
        return out

    def predict_xy(self, xy, velocity, heading_rad, length_m, width_m, is_pedestrian,
                   times_s) -> np.ndarray:
        """(M, T, 2) predicted centres [m] at future times (T,) [s] (the module docstring).

        Args:
            xy: (M, 2) centres [m].
            velocity: (M, 2) velocities [m/s].
            heading_rad: (M,) headings [rad].
            length_m: (M,) footprint lengths [m].
            width_m: (M,) footprint widths [m].
            is_pedestrian: (M,) bool.
            times_s: (T,) prediction times >= 0 [s].
        """
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        velocity = np.asarray(velocity, dtype=np.float64).reshape(-1, 2)
        times_s = np.asarray(times_s, dtype=np.float64)
        pred = xy[:, None, :] + velocity[:, None, :] * times_s[None, :, None]
        if not self._zones or not len(xy):
            return pred
        gap = self.stop_distance_m(xy, velocity, heading_rad, length_m, width_m, is_pedestrian)
        speed = np.hypot(velocity[:, 0], velocity[:, 1])
        stops = np.isfinite(gap) & (speed * speed <= 2.0 * self.decel_mps2 * gap)
        if not stops.any():
            return pred
        v, d = speed[stops], gap[stops]
        decel = v * v / (2.0 * d)  # (K,) [m/s^2]
        t = np.minimum(times_s[None, :], (v / decel)[:, None])  # (K, T) until it rests
        travelled = v[:, None] * t - 0.5 * decel[:, None] * t * t  # (K, T) [m]
        direction = velocity[stops] / v[:, None]
        pred[stops] = xy[stops, None, :] + travelled[:, :, None] * direction[:, None, :]
        return pred
