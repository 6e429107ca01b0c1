"""The env's observation limits and its global state (PettingZoo `state()` / `state_space`).

Global state: one flat float32 vector over `possible_agents` (a fixed size, whatever agents are
still in the episode), STATE_DIM values per agent in `possible_agents` order:

    [ x [m], y [m], cos(psi), sin(psi), v [m/s], active (0/1) ] * n_agents

followed, on a map with traffic signals, by every signal head's true state one-hot
(SIGNAL_STATE_DIM values per head, in `RoadMap.signal_heads` order: red, yellow, green;
sim/signals.py) -- the phase no agent may see unless its head is in view.

It is the true state, for centralized critics (CTDE); planners never receive it. An agent that
has left the episode (terminated or truncated) has an all-zero row, active 0.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import OBS_BOUND, ObservationLimits, position_bounds

STATE_FIELDS = ("x", "y", "cos_psi", "sin_psi", "v", "active")
STATE_DIM = len(STATE_FIELDS)
STATE_INDEX = {name: i for i, name in enumerate(STATE_FIELDS)}  # field -> column of a row
SIGNAL_STATE_DIM = 3  # one-hot per signal head: red, yellow, green (sim/signals.py states 0-2)


def _speed_max_mps(spec) -> float:
    return spec.pedestrian.speed_max_mps if spec.kind == "pedestrian" else spec.vehicle.speed_max_mps


def _size_max_m(spec) -> float:
    if spec.kind == "pedestrian":
        return 2.0 * spec.pedestrian.radius_m
    return max(spec.vehicle.length_m, spec.vehicle.width_m)


def env_limits(layout, max_cycles: int) -> ObservationLimits:
    """The physical limits of a scenario's agents over an episode of `max_cycles` steps.

    Args:
        layout: a ScenarioLayout (its road map and agent specs).
        max_cycles: the episode's step limit.
    """
    specs = layout.agents
    speed_max = max(_speed_max_mps(s) for s in specs)
    return ObservationLimits(
        extent_m=tuple(float(v) for v in layout.road_map.extent),
        reach_m=min(speed_max * DT_S * max_cycles, OBS_BOUND),
        speed_max_mps=speed_max,
        sensor_range_max_m=max(s.sensor.range_m for s in specs),
        half_angle_max_rad=max(s.sensor.half_angle_rad for s in specs),
        size_max_m=max(_size_max_m(s) for s in specs),
        n_agents=len(specs),
        pos_noise_max_m=max(s.sensor.pos_noise_m for s in specs),
        vel_noise_max_mps=max(s.sensor.vel_noise_mps for s in specs),
    )


def state_space(limits: ObservationLimits, specs, n_signals: int = 0) -> spaces.Box:
    """The (n_agents * STATE_DIM + n_signals * SIGNAL_STATE_DIM,) float32 Box of the state.

    Args:
        limits: the env's limits (positions: the map's extent grown by the agents' reach, and
            0).
        specs: the agents' specs in `possible_agents` order (each row's speed bound is its own
            agent's top speed).
        n_signals: the map's signal heads (each adds a one-hot block in [0, 1]).
    """
    x, y = position_bounds(limits.extent_m, limits.reach_m)  # with 0: the row of one gone
    low = np.array([x[0], y[0], -1.0, -1.0, 0.0, 0.0])
    high = np.array([x[1], y[1], 1.0, 1.0, 0.0, 1.0])
    lows = np.tile(low, (len(specs), 1))  # (n, STATE_DIM)
    highs = np.tile(high, (len(specs), 1))
    highs[:, STATE_INDEX["v"]] = [_speed_max_mps(s) for s in specs]
    signal_bounds = np.zeros(n_signals * SIGNAL_STATE_DIM), np.ones(n_signals * SIGNAL_STATE_DIM)
    return spaces.Box(np.concatenate([lows.ravel(), signal_bounds[0]]).astype(np.float32),
                      np.concatenate([highs.ravel(), signal_bounds[1]]).astype(np.float32),
                      dtype=np.float32)


def encode_state(state: np.ndarray, live: np.ndarray,
                 signal_states: np.ndarray | None = None) -> np.ndarray:
    """The global state vector.

    Args:
        state: (n, 4) true states [x m, y m, heading rad, speed m/s] in `possible_agents` order.
        live: (n,) bool, the agents still in the episode.
        signal_states: (H,) int, the state every signal head shows (0 red, 1 yellow, 2 green;
            None or empty: a map without signals).

    Returns:
        (n * STATE_DIM + H * SIGNAL_STATE_DIM,) float32; rows of agents not live are zero.
    """
    rows = np.column_stack([state[:, :2], np.cos(state[:, 2]), np.sin(state[:, 2]), state[:, 3],
                            np.ones(len(state))])
    rows[~live] = 0.0
    heads = np.zeros(0, dtype=np.int64) if signal_states is None else np.asarray(signal_states)
    one_hot = np.eye(SIGNAL_STATE_DIM)[heads.astype(np.int64)].ravel()
    return np.concatenate([rows.ravel(), one_hot]).astype(np.float32)
