"""Per-agent physical, sensor and planner parameters (frozen dataclasses, SI units)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from marl_social.sim.costs import CostWeights

AgentKind = Literal["vehicle", "pedestrian"]
AgentRole = Literal["robot", "human", "pedestrian"]


@dataclass(frozen=True)
class VehicleParams:
    """Kinematic-bicycle vehicle.

    Attributes:
        length_m, width_m: footprint [m].
        wheelbase_m: axle distance [m]; the model's reference point is the footprint centre,
            with the rear axle at wheelbase/2 behind it.
        accel_max_mps2: largest forward acceleration [m/s^2].
        brake_max_mps2: largest deceleration (positive number) [m/s^2].
        steer_max_rad: steering angle limit |delta| [rad].
        lat_accel_max_mps2: lateral acceleration limit (G-G diagram) [m/s^2]; steering saturates
            at min(steer_max, atan(wheelbase * lat_accel_max / v^2)).
        speed_max_mps: top speed [m/s]; speed is also kept >= 0 (no reversing).
    """

    length_m: float = 4.5
    width_m: float = 1.8
    wheelbase_m: float = 2.7
    accel_max_mps2: float = 3.0
    brake_max_mps2: float = 8.0
    steer_max_rad: float = 0.6
    lat_accel_max_mps2: float = 6.0
    speed_max_mps: float = 20.0


@dataclass(frozen=True)
class PedestrianParams:
    """Pedestrian as a disc with a velocity command.

    Attributes:
        radius_m: disc radius [m].
        speed_max_mps: the commanded velocity's norm saturates here [m/s].
    """

    radius_m: float = 0.3
    speed_max_mps: float = 2.0


@dataclass(frozen=True)
class SensorParams:
    """A field of view and its measurement noise.

    Attributes:
        range_m: maximum sensing distance [m].
        half_angle_rad: half-angle of the view cone around the heading [rad] (pi = all round).
        pos_noise_m: std of the Gaussian noise added to measured positions [m].
        vel_noise_mps: std of the noise on measured velocities [m/s].
        heading_noise_rad: std of the noise on measured headings [rad].
        blind_regions: convex polygons (V, 2) [m] in which this agent sees nothing (an object
            whose centre is inside one is invisible to it: distraction, an A-pillar, glare).
    """

    range_m: float = 50.0
    half_angle_rad: float = math.radians(70.0)
    pos_noise_m: float = 0.05
    vel_noise_mps: float = 0.1
    heading_noise_rad: float = 0.01
    blind_regions: tuple = ()


@dataclass(frozen=True)
class AgentSpec:
    """One agent of a scenario.

    Attributes:
        name: PettingZoo agent name (`robot_0`, `human_0`, `pedestrian_0`, ...).
        kind: "vehicle" or "pedestrian" (selects dynamics and action layout).
        role: "robot", "human" or "pedestrian".
        initial_state: (4,) [x m, y m, heading rad, speed m/s].
        sensor: its own field of view.
        vehicle / pedestrian: physical parameters for its kind.
        v_desired_mps: the speed it wants to travel at [m/s] (its v_ref in the speed cost).
        cost_weights: its own theta (sim/costs.py), used for its reward and by its planner.
        planner: the agent's private planner parameters (crossing intent, rationality, ...);
            its own policy may read them, nobody else's may.
    """

    name: str
    kind: AgentKind
    role: AgentRole
    initial_state: np.ndarray
    sensor: SensorParams = field(default_factory=SensorParams)
    vehicle: VehicleParams = field(default_factory=VehicleParams)
    pedestrian: PedestrianParams = field(default_factory=PedestrianParams)
    v_desired_mps: float = 11.5
    cost_weights: CostWeights = field(default_factory=CostWeights)
    planner: dict = field(default_factory=dict)

    @property
    def bounding_radius_m(self) -> float:
        """Radius of the smallest centre-based circle containing the footprint [m]."""
        if self.kind == "pedestrian":
            return self.pedestrian.radius_m
        return 0.5 * math.hypot(self.vehicle.length_m, self.vehicle.width_m)
