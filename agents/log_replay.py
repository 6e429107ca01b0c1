"""Log replay: a vehicle that drives its recorded motion (a track of a recorded scene).

The recorded path is the agent's route; the policy steers along it by pure pursuit and sets the
acceleration that brings its arc length and speed to the recording's at the next step:

    a = (v_rec(t + dt) - v) / dt + POSITION_GAIN_PER_S2 * (s_rec(t + dt) - s - v dt)

through the vehicle's dynamics, so it is not teleported: its motion is the recording's to the
tracking error (reported by the caller) and its own field of view is computed as any agent's.
It ignores what it sees: it reacts to nothing in the simulation, only to what it reacted to in
the recording. Past the recording's end it drives to its route's end and so leaves the episode.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from marl_social.models.steering import pure_pursuit
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import ObservationLayout
from marl_social.sim.road_map import RoadMap

POSITION_GAIN_PER_S2 = 1.0  # pull towards the recorded arc length [1/s^2]


class RecordedMotion(NamedTuple):
    """One vehicle's recorded motion along its route (K samples).

    Attributes:
        t_s: (K,) times since the replay's start [s], increasing.
        s_m: (K,) arc length along the recorded path (the agent's route) [m].
        v_mps: (K,) speed [m/s].
    """

    t_s: np.ndarray
    s_m: np.ndarray
    v_mps: np.ndarray

    def at(self, t_s: float) -> tuple[float, float]:
        """(arc length [m], speed [m/s]) at time t_s; the last sample's position past the end."""
        if t_s > self.t_s[-1]:
            return float(self.s_m[-1]) + 1.0, 0.0  # on to the route's end: the agent leaves
        return (float(np.interp(t_s, self.t_s, self.s_m)),
                float(np.interp(t_s, self.t_s, self.v_mps)))


class LogReplayPolicy:
    """Drives the agent along its recorded motion (module docstring).

    Args:
        spec: the vehicle's AgentSpec.
        layout: the shared observation layout.
        road_map: the static map with the agent's route (its recorded path).
        motion: the recorded motion along that route.
    """

    needs_truth = False

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap,
                 motion: RecordedMotion):
        self.name = spec.name
        self.layout = layout
        self.route = road_map.routes[spec.name]
        self.wheelbase_m = spec.vehicle.wheelbase_m
        self.motion = motion
        self.steps = 0

    def reset(self, seed: int | None = None) -> None:
        """Back to the recording's start (the seed is unused: a replay draws nothing)."""
        self.steps = 0

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The (2,) [acceleration m/s^2, steering rad] towards the next recorded sample."""
        x, y, cos_psi, sin_psi, v = self.layout.decode(obs).ego[:5]
        s_now, _, _ = self.route.project(np.array([x, y]))
        self.steps += 1
        s_next, v_next = self.motion.at(self.steps * DT_S)
        accel = ((v_next - v) / DT_S
                 + POSITION_GAIN_PER_S2 * (s_next - float(s_now) - v * DT_S))
        steer = pure_pursuit(self.route, x, y, math.atan2(sin_psi, cos_psi), v, float(s_now),
                             self.wheelbase_m)
        return np.array([accel, steer], dtype=np.float32)
