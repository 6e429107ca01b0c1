"""Physical metrics of the robot (group "episode"): collisions, speeds, braking, crosswalk.

Measured against the first pedestrian and the first crosswalk of the map. Each metric is a
short function of (trace, road_map, robot) registered in `marl_social.metrics.registry`; the
helpers below give the per-agent series they share.
"""

from __future__ import annotations

import numpy as np

from marl_social.metrics.registry import register_metric
from marl_social.sim.costs import crosswalk_occupancy
from marl_social.sim.dynamics import DT_S
from marl_social.sim.road_map import RoadMap
from marl_social.sim.trace import Trace

HARD_BRAKE_MPS2 = 5.0  # braking harder than this counts as a hard brake [m/s^2]
OCCUPIED_FRACTION = 0.5  # crosswalk_occupancy above this counts as "in the crosswalk"
PASSED_FRACTION = 0.01  # ... and below this as clear of it
NAN = float("nan")


# ------------------------------------------------------------------------------ shared series


def pedestrian_indices(trace: Trace) -> list[int]:
    """Trace indices of the agents whose role is "pedestrian", in trace order."""
    return [i for i, role in enumerate(trace.roles) if role == "pedestrian"]


def agent_occupancy(trace: Trace, agent: int, road_map: RoadMap) -> np.ndarray:
    """(T+1,) occupancy of the first crosswalk by one agent's bounding circle, in [0, 1].

    Args:
        trace: the episode's trace.
        agent: trace index of the agent.
        road_map: the map; it must have a crosswalk.
    """
    return crosswalk_occupancy(trace.states[:, agent, :2], trace.bounding_radius_m[agent],
                               road_map.crosswalks[0])


def _robot_speeds(trace: Trace, robot: str) -> np.ndarray:
    """(n_active,) the robot's speeds while active [m/s]."""
    r = trace.index(robot)
    return trace.states[:, r][trace.active[:, r], 3]


def _robot_accel(trace: Trace, robot: str) -> np.ndarray:
    """(n_active_steps,) the robot's applied accelerations in the steps it starts active [m/s^2]."""
    r = trace.index(robot)
    if not len(trace.accel_mps2):
        return np.zeros(0)
    return trace.accel_mps2[:, r][trace.active[1:, r]]


def _max_decel_mps2(trace: Trace, robot: str) -> float:
    """Largest braking of the robot [m/s^2] (>= 0; 0 without steps)."""
    accel = _robot_accel(trace, robot)
    return float(max(0.0, -accel.min())) if len(accel) else 0.0


# ------------------------------------------------------------------------------ metrics


@register_metric("collision", "robot_collision", group="episode")
def collisions(trace: Trace, road_map: RoadMap, robot: str) -> tuple[bool, bool]:
    """Any agent touched anything; the robot touched anything."""
    if not len(trace.collided):
        return False, False
    return bool(trace.collided.any()), bool(trace.collided[:, trace.index(robot)].any())


@register_metric("mean_speed_mps", "min_speed_mps", group="episode")
def robot_speeds(trace: Trace, road_map: RoadMap, robot: str) -> tuple[float, float]:
    """Mean and smallest robot speed while active [m/s] (nan if never active)."""
    speeds = _robot_speeds(trace, robot)
    if not len(speeds):
        return NAN, NAN
    return float(speeds.mean()), float(speeds.min())


@register_metric("max_decel_mps2", "max_jerk_mps3", group="episode")
def robot_braking(trace: Trace, road_map: RoadMap, robot: str) -> tuple[float, float]:
    """Largest braking [m/s^2] (>= 0) and largest |change of acceleration| / dt [m/s^3]."""
    accel = _robot_accel(trace, robot)
    jerk = float(np.abs(np.diff(accel)).max() / DT_S) if len(accel) > 1 else 0.0
    return _max_decel_mps2(trace, robot), jerk


@register_metric("min_gap_pedestrian_m", group="episode")
def min_gap_pedestrian(trace: Trace, road_map: RoadMap, robot: str) -> float:
    """Smallest robot-pedestrian centre distance minus both bounding radii [m], >= 0.

    Conservative for the car's long sides; nan without a crosswalk, without a pedestrian or if
    the two are never active together.
    """
    peds = pedestrian_indices(trace)
    if not road_map.crosswalks or not peds:
        return NAN
    r, p = trace.index(robot), peds[0]
    both = trace.active[:, r] & trace.active[:, p]
    if not both.any():
        return NAN
    gaps = (np.linalg.norm(trace.states[:, r, :2] - trace.states[:, p, :2], axis=1)
            - trace.bounding_radius_m[r] - trace.bounding_radius_m[p])
    return float(max(gaps[both].min(), 0.0))


@register_metric("yielded", group="episode")
def yielded(trace: Trace, road_map: RoadMap, robot: str) -> bool:
    """The robot was never in the crosswalk while the pedestrian was in it (True without)."""
    peds = pedestrian_indices(trace)
    if not road_map.crosswalks or not peds:
        return True
    r, p = trace.index(robot), peds[0]
    robot_in = (agent_occupancy(trace, r, road_map) > OCCUPIED_FRACTION) & trace.active[:, r]
    ped_in = agent_occupancy(trace, p, road_map) > OCCUPIED_FRACTION
    return not bool(np.any(robot_in & ped_in & trace.active[:, p]))


@register_metric("time_to_pass_s", group="episode")
def time_to_pass(trace: Trace, road_map: RoadMap, robot: str) -> float:
    """Time until the robot's bounding circle has entered and left the crosswalk [s].

    The first time the robot no longer touches the crosswalk after touching it; nan if never
    or without a crosswalk.
    """
    if not road_map.crosswalks:
        return NAN
    occupancy = agent_occupancy(trace, trace.index(robot), road_map)
    entered = np.cumsum(occupancy > PASSED_FRACTION) > 0
    passed = np.flatnonzero(entered & (occupancy <= PASSED_FRACTION))
    return float(trace.times_s[passed[0]]) if len(passed) else NAN


@register_metric("hard_brake", group="episode")
def hard_brake(trace: Trace, road_map: RoadMap, robot: str) -> bool:
    """max_decel_mps2 > HARD_BRAKE_MPS2."""
    return _max_decel_mps2(trace, robot) > HARD_BRAKE_MPS2
