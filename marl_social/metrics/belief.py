"""Belief metrics (group "belief"): the robot's belief in a crossing pedestrian.

The belief is trace.extras["p_pedestrian"], (T+1,), NaN once the robot has left the episode;
metrics that need it are nan (or False) when the trace has none, and those that need a
pedestrian or a crosswalk are nan without one. Each metric is a short function of
(trace, road_map, robot) registered in `marl_social.metrics.registry`.
"""

from __future__ import annotations

import numpy as np

from marl_social.metrics.physical import (
    NAN,
    OCCUPIED_FRACTION,
    agent_occupancy,
    pedestrian_indices,
)
from marl_social.metrics.registry import register_metric
from marl_social.sim.road_map import RoadMap
from marl_social.sim.trace import Trace

BELIEF_CONFIDENT = 0.9  # a belief above this counts as confident that a pedestrian crosses
HUMAN_BRAKE_MPS2 = -1.0  # a human's braking onset: first acceleration below this [m/s^2]


# ------------------------------------------------------------------------------ shared series


def _belief(trace: Trace) -> np.ndarray | None:
    """(T+1,) the robot's belief in a crossing pedestrian, or None if not recorded."""
    belief = trace.extras.get("p_pedestrian")
    return None if belief is None else np.asarray(belief)


def _robot_sees_pedestrian(trace: Trace, robot: str) -> np.ndarray:
    """(T+1,) bool: the robot sees at least one pedestrian."""
    peds = pedestrian_indices(trace)
    if not peds:
        return np.zeros(len(trace.times_s), dtype=bool)
    return trace.visible[:, trace.index(robot), peds].any(axis=1)


def _first_seen_index(trace: Trace, robot: str) -> int:
    """Step at which the robot first sees a pedestrian (T+1 if never)."""
    sees = _robot_sees_pedestrian(trace, robot)
    return int(np.argmax(sees)) if sees.any() else len(trace.times_s)


# ------------------------------------------------------------------------------ metrics


@register_metric("robot_first_sees_pedestrian_s", group="belief")
def robot_first_sees_pedestrian(trace: Trace, road_map: RoadMap, robot: str) -> float:
    """First time the robot sees a pedestrian [s] (nan if never)."""
    sees = _robot_sees_pedestrian(trace, robot)
    return float(trace.times_s[np.argmax(sees)]) if sees.any() else NAN


@register_metric("p_pedestrian_before_seen", group="belief")
def p_pedestrian_before_seen(trace: Trace, road_map: RoadMap, robot: str) -> float:
    """Belief at the last step before the robot first sees a pedestrian."""
    belief, first_seen = _belief(trace), _first_seen_index(trace, robot)
    if belief is None or first_seen == 0:
        return NAN
    return float(belief[first_seen - 1])


@register_metric("brake_to_confident_s", group="belief")
def brake_to_confident(trace: Trace, road_map: RoadMap, robot: str) -> float:
    """From the first human's braking onset to belief > BELIEF_CONFIDENT [s].

    Braking onset: the first step in which any human accelerates below HUMAN_BRAKE_MPS2; nan
    if either never happens.
    """
    belief = _belief(trace)
    humans = [i for i, role in enumerate(trace.roles) if role == "human"]
    if belief is None or not humans or not len(trace.accel_mps2):
        return NAN
    braking = (trace.accel_mps2[:, humans] < HUMAN_BRAKE_MPS2).any(axis=1)
    confident = belief[1:] > BELIEF_CONFIDENT
    if not (braking.any() and confident.any()):
        return NAN
    times = trace.times_s
    return float(times[1 + np.argmax(confident)] - times[1 + np.argmax(braking)])


@register_metric("p_pedestrian_at_crosswalk", group="belief")
def p_pedestrian_at_crosswalk(trace: Trace, road_map: RoadMap, robot: str) -> float:
    """Belief when the robot's bounding circle first reaches the crosswalk."""
    belief = _belief(trace)
    if belief is None or not road_map.crosswalks:
        return NAN
    reached = agent_occupancy(trace, trace.index(robot), road_map) > OCCUPIED_FRACTION
    return float(belief[np.argmax(reached)]) if reached.any() else NAN


@register_metric("max_p_pedestrian_unseen", group="belief")
def max_p_pedestrian_unseen(trace: Trace, road_map: RoadMap, robot: str) -> float:
    """Largest belief while no pedestrian is visible to the robot (and the robot is active)."""
    belief = _belief(trace)
    if belief is None:
        return NAN
    unseen = ~_robot_sees_pedestrian(trace, robot) & np.isfinite(belief)
    return float(belief[unseen].max()) if unseen.any() else NAN


@register_metric("brier", group="belief")
def brier(trace: Trace, road_map: RoadMap, robot: str) -> float:
    """Mean squared error of the belief against the truth.

    Truth 1 if a pedestrian enters the crosswalk during the episode, else 0; nan without a
    crosswalk.
    """
    belief = _belief(trace)
    if belief is None or not road_map.crosswalks:
        return NAN
    truth = 0.0
    for p in pedestrian_indices(trace):
        if np.any((agent_occupancy(trace, p, road_map) > OCCUPIED_FRACTION) & trace.active[:, p]):
            truth = 1.0
    return float(np.nanmean((belief - truth) ** 2))


@register_metric("belief_confident_before_seen", group="belief")
def belief_confident_before_seen(trace: Trace, road_map: RoadMap, robot: str) -> bool:
    """The belief exceeded BELIEF_CONFIDENT before the robot first saw a pedestrian."""
    belief, first_seen = _belief(trace), _first_seen_index(trace, robot)
    if belief is None or first_seen == 0:
        return False
    return bool((belief[:first_seen] > BELIEF_CONFIDENT).any())
