"""The one observation layout shared by all agents (a flat float32 vector).

    [ ego (EGO_DIM) | K object slots (K * SLOT_DIM) | depth rays (n_rays) ]

ego:   x, y [m], cos(psi), sin(psi), v [m/s], sensor range [m], sensor half-angle [rad],
       is_pedestrian (0/1). Ego state is the agent's own odometry: exact.
slot:  present (0/1), object id (agent index + 1; 0 = empty), x, y [m], vx, vy [m/s],
       cos(psi), sin(psi), length [m], width [m], is_pedestrian (0/1) — a noisy measurement of a
       *visible* object; slots are filled nearest first, the rest are zero.
rays:  distance to the first hit along each depth ray [m] (the visibility polygon); ray i points
       at heading + ray_angle(i), angles spread evenly over the agent's cone, edges included
       (`perception.fov.depth_ray_angles`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

EGO_FIELDS = ("x", "y", "cos_psi", "sin_psi", "v", "sensor_range", "sensor_half_angle",
              "is_pedestrian")
SLOT_FIELDS = ("present", "id", "x", "y", "vx", "vy", "cos_psi", "sin_psi", "length", "width",
               "is_pedestrian")
EGO_DIM = len(EGO_FIELDS)
EGO_INDEX = {name: i for i, name in enumerate(EGO_FIELDS)}  # field name -> column of the ego block
SLOT_INDEX = {name: i for i, name in enumerate(SLOT_FIELDS)}  # field name -> column of a slot
OBS_BOUND = 1.0e5  # [m]; worlds larger than 100 km are out of scope
SLOT_DIM = len(SLOT_FIELDS)


@dataclass(frozen=True)
class Measurements:
    """Measured objects, one row per visible (observer, target) pair.

    Rows are sorted by observer then true distance.

    Attributes:
        observer: (P,) index of the observing agent.
        target: (P,) index of the observed agent.
        xy: (P, 2) measured position [m].
        velocity: (P, 2) measured velocity [m/s].
        heading: (P,) measured heading [rad].
        distance_m: (P,) true centre distance, for slot ordering [m].
    """

    observer: np.ndarray
    target: np.ndarray
    xy: np.ndarray
    velocity: np.ndarray
    heading: np.ndarray
    distance_m: np.ndarray


@dataclass(frozen=True)
class DecodedObservation:
    """A structured view of one observation vector.

    Attributes:
        ego: (EGO_DIM,) see EGO_FIELDS.
        slots: (K, SLOT_DIM) see SLOT_FIELDS.
        depth_m: (n_rays,) [m].
    """

    ego: np.ndarray
    slots: np.ndarray
    depth_m: np.ndarray

    @property
    def objects(self) -> np.ndarray:
        """(k, SLOT_DIM) the present slots only."""
        return self.slots[self.slots[:, 0] > 0.5]


@dataclass(frozen=True)
class ObservationLayout:
    """Sizes of the shared layout: n_slots object slots K and n_rays depth rays."""

    n_slots: int
    n_rays: int

    @property
    def size(self) -> int:
        return EGO_DIM + self.n_slots * SLOT_DIM + self.n_rays

    def space(self) -> spaces.Box:
        """Box with finite bounds.

        Coordinates lie within +-OBS_BOUND (100 km), every other field far inside that.
        """
        return spaces.Box(-OBS_BOUND, OBS_BOUND, shape=(self.size,), dtype=np.float32)

    def slot_index(self, field: str) -> int:
        return SLOT_FIELDS.index(field)

    def decode(self, obs) -> DecodedObservation:
        obs = np.asarray(obs)
        if obs.shape != (self.size,):
            raise ValueError(f"observation: expected shape ({self.size},), got {obs.shape}")
        k0 = EGO_DIM
        k1 = k0 + self.n_slots * SLOT_DIM
        return DecodedObservation(
            obs[:k0], obs[k0:k1].reshape(self.n_slots, SLOT_DIM), obs[k1:]
        )

    def encode(self, xy, heading, speed, sensor_range, sensor_half_angle, is_pedestrian,
               length, width, measurements: Measurements, depth_m) -> np.ndarray:
        """Observation vectors of all n agents.

        Args:
            xy: (n, 2) true positions [m].
            heading: (n,) true headings [rad].
            speed: (n,) true speeds [m/s].
            sensor_range: (n,) sensor range of each agent [m].
            sensor_half_angle: (n,) sensor half-angle of each agent [rad].
            is_pedestrian: (n,) bool.
            length: (n,) footprint lengths [m].
            width: (n,) footprint widths [m].
            measurements: visible pairs, sorted by observer then distance.
            depth_m: (n, n_rays) depth ray distances [m].

        Returns:
            (n, size) float32.
        """
        n = len(xy)
        out = np.zeros((n, self.size), dtype=np.float32)
        out[:, 0:2] = xy
        out[:, 2] = np.cos(heading)
        out[:, 3] = np.sin(heading)
        out[:, 4] = speed
        out[:, 5] = sensor_range
        out[:, 6] = sensor_half_angle
        out[:, 7] = is_pedestrian
        m = measurements
        if len(m.observer):
            first = np.searchsorted(m.observer, m.observer, side="left")
            rank = np.arange(len(m.observer)) - first
            keep = rank < self.n_slots
            obs_i, rank, tgt = m.observer[keep], rank[keep], m.target[keep]
            slot = np.column_stack([
                np.ones(len(tgt)), tgt + 1.0, m.xy[keep], m.velocity[keep],
                np.cos(m.heading[keep]), np.sin(m.heading[keep]), length[tgt], width[tgt],
                is_pedestrian[tgt].astype(np.float64),
            ])
            slots = out[:, EGO_DIM:EGO_DIM + self.n_slots * SLOT_DIM].reshape(
                n, self.n_slots, SLOT_DIM
            )
            slots[obs_i, rank] = slot
        out[:, EGO_DIM + self.n_slots * SLOT_DIM:] = depth_m
        return out
