"""The per-step record of one episode (the trace), filled by a rollout, read by metrics and figures."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Trace:
    """Per-step record of one episode (T steps, n agents, in env.possible_agents order).

    Attributes:
        names: (n,) agent names; roles: (n,) "robot" / "human" / "pedestrian".
        times_s: (T+1,) time of each recorded state [s] (index 0 = reset).
        states: (T+1, n, 4) true [x m, y m, heading rad, speed m/s].
        active: (T+1, n) bool, agent still in the episode.
        visible: (T+1, n, n) bool, visible[t, o, j]: agent o sees agent j.
        actions: (T, n, 2) applied (saturated) actions.
        accel_mps2: (T, n) longitudinal acceleration applied in each step [m/s^2].
        rewards: (T, n).
        collided: (T, n) bool.
        frames: rendered RGB frames, if requested.
        extras: free-form per-step series added by callers (e.g. beliefs), name -> (T+1,) array.
        signal_states: (T+1, H) int8, the state each of the map's H signal heads showed
            (sim/signals.py: RED 0, YELLOW 1, GREEN 2; H = 0 on a map without signals).
        bounding_radius_m: (n,) footprint bounding radii [m].
    """

    names: list
    roles: list
    bounding_radius_m: np.ndarray
    times_s: list = field(default_factory=list)
    states: list = field(default_factory=list)
    active: list = field(default_factory=list)
    visible: list = field(default_factory=list)
    actions: list = field(default_factory=list)
    accel_mps2: list = field(default_factory=list)
    rewards: list = field(default_factory=list)
    collided: list = field(default_factory=list)
    frames: list = field(default_factory=list)
    extras: dict = field(default_factory=dict)
    signal_states: list = field(default_factory=list)

    def index(self, name: str) -> int:
        return self.names.index(name)

    def finalize(self) -> Trace:
        """Stack the recorded lists into arrays (call once, after the episode)."""
        for key in ("times_s", "states", "active", "visible", "actions", "accel_mps2",
                    "rewards", "collided"):
            setattr(self, key, np.asarray(getattr(self, key)))
        n_heads = len(self.signal_states[0]) if len(self.signal_states) else 0
        self.signal_states = np.asarray(self.signal_states, dtype=np.int8).reshape(
            len(self.signal_states), n_heads)
        return self
