"""Episode metrics (one module for all of them), computed from a Trace.

Physical metrics of the robot (`robot_0`) with respect to the first pedestrian and the first
crosswalk; belief metrics are added by the robot issue's code from trace.extras.
"""

from __future__ import annotations

import numpy as np

from marl_social.sim.costs import crosswalk_occupancy
from marl_social.sim.dynamics import DT_S
from marl_social.sim.road_map import RoadMap
from marl_social.sim.trace import Trace

HARD_BRAKE_MPS2 = 5.0
_OCCUPIED = 0.5  # crosswalk_occupancy above this counts as "in the crosswalk"
_PASSED = 0.01  # ... and below this as clear of it


def episode_metrics(trace: Trace, road_map: RoadMap, robot: str = "robot_0") -> dict:
    """Metrics of one episode.

    Returns a dict of floats / bools:
        collision: any agent touched anything.
        robot_collision: the robot touched anything.
        min_gap_pedestrian_m: smallest centre distance robot-pedestrian minus both bounding
            radii [m], >= 0 (nan without pedestrian; conservative for the car's long sides).
        yielded: the robot was never in the crosswalk while the pedestrian was in it.
        time_to_pass_s: time until the robot's footprint (bounding circle) has entered and left
            the crosswalk [s] (nan if never).
        mean_speed_mps, min_speed_mps: robot speeds while active [m/s].
        max_decel_mps2: largest braking of the robot [m/s^2] (>= 0).
        max_jerk_mps3: largest |change of robot acceleration| / dt [m/s^3].
        hard_brake: max_decel > HARD_BRAKE_MPS2.
    """
    r = trace.index(robot)
    active = trace.active[:, r]
    states = trace.states[:, r]
    speeds = states[active, 3]
    accel = trace.accel_mps2[:, r][active[1:]] if len(trace.accel_mps2) else np.zeros(0)
    peds = [i for i, role in enumerate(trace.roles) if role == "pedestrian"]
    out = {
        "collision": bool(trace.collided.any()) if len(trace.collided) else False,
        "robot_collision": bool(trace.collided[:, r].any()) if len(trace.collided) else False,
        "mean_speed_mps": float(speeds.mean()) if len(speeds) else float("nan"),
        "min_speed_mps": float(speeds.min()) if len(speeds) else float("nan"),
        "max_decel_mps2": float(max(0.0, -accel.min())) if len(accel) else 0.0,
        "max_jerk_mps3": float(np.abs(np.diff(accel)).max() / DT_S) if len(accel) > 1 else 0.0,
        "min_gap_pedestrian_m": float("nan"),
        "yielded": True,
        "time_to_pass_s": float("nan"),
    }
    out["hard_brake"] = out["max_decel_mps2"] > HARD_BRAKE_MPS2
    robot_radius = trace.bounding_radius_m[r]
    if road_map.crosswalks:
        cw = road_map.crosswalks[0]
        occupancy = crosswalk_occupancy(states[:, :2], robot_radius, cw)
        robot_in = (occupancy > _OCCUPIED) & active
        # passed: the first time the robot no longer touches the crosswalk after touching it
        entered = np.cumsum(occupancy > _PASSED) > 0
        passed = np.flatnonzero(entered & (occupancy <= _PASSED))
        if len(passed):
            out["time_to_pass_s"] = float(trace.times_s[passed[0]])
        if peds:
            p = peds[0]
            ped_states = trace.states[:, p]
            ped_radius = trace.bounding_radius_m[p]
            both = active & trace.active[:, p]
            gaps = (np.linalg.norm(states[:, :2] - ped_states[:, :2], axis=1) - robot_radius
                    - ped_radius)
            if both.any():
                out["min_gap_pedestrian_m"] = float(max(gaps[both].min(), 0.0))
            ped_in = crosswalk_occupancy(ped_states[:, :2], ped_radius, cw) > _OCCUPIED
            out["yielded"] = not bool(np.any(robot_in & ped_in & trace.active[:, p]))
    return out


BELIEF_CONFIDENT = 0.9
HUMAN_BRAKE_MPS2 = -1.0  # a human's braking onset: first acceleration below this [m/s^2]


def belief_metrics(trace: Trace, road_map: RoadMap, robot: str = "robot_0") -> dict:
    """Metrics of the robot's belief in a crossing pedestrian (trace.extras["p_pedestrian"],
    (T+1,)); nan where the trace has no belief or no pedestrian.

    Returns:
        robot_first_sees_pedestrian_s: first time the robot sees a pedestrian [s].
        p_pedestrian_before_seen: belief at the last step before the robot first sees it.
        belief_confident_before_seen: belief exceeded BELIEF_CONFIDENT before the robot saw it.
        brake_to_confident_s: from the first human's braking onset to belief > BELIEF_CONFIDENT
            [s] (nan if either never happens).
        p_pedestrian_at_crosswalk: belief when the robot's footprint first reaches the crosswalk.
        max_p_pedestrian_unseen: largest belief while no pedestrian is visible to the robot.
        brier: mean squared error of the belief against the truth (a pedestrian that enters the
            crosswalk during the episode = 1).
    """
    nan = float("nan")
    out = {k: nan for k in ("robot_first_sees_pedestrian_s", "p_pedestrian_before_seen",
                            "brake_to_confident_s", "p_pedestrian_at_crosswalk",
                            "max_p_pedestrian_unseen", "brier")}
    out["belief_confident_before_seen"] = False
    belief = trace.extras.get("p_pedestrian")
    r = trace.index(robot)
    peds = [i for i, role in enumerate(trace.roles) if role == "pedestrian"]
    times = trace.times_s
    sees = (trace.visible[:, r, peds].any(axis=1) if peds
            else np.zeros(len(times), dtype=bool))
    if sees.any():
        out["robot_first_sees_pedestrian_s"] = float(times[np.argmax(sees)])
    if belief is None:
        return out
    belief = np.asarray(belief)
    first_seen = int(np.argmax(sees)) if sees.any() else len(times)
    if first_seen > 0:
        out["p_pedestrian_before_seen"] = float(belief[first_seen - 1])
        out["belief_confident_before_seen"] = bool((belief[:first_seen] > BELIEF_CONFIDENT).any())
    unseen = ~sees & np.isfinite(belief)  # NaN once the robot has left the episode
    if unseen.any():
        out["max_p_pedestrian_unseen"] = float(belief[unseen].max())
    humans = [i for i, role in enumerate(trace.roles) if role == "human"]
    if humans and len(trace.accel_mps2):
        braking = (trace.accel_mps2[:, humans] < HUMAN_BRAKE_MPS2).any(axis=1)
        confident = belief[1:] > BELIEF_CONFIDENT
        if braking.any() and confident.any():
            out["brake_to_confident_s"] = float(
                times[1 + np.argmax(confident)] - times[1 + np.argmax(braking)])
    if road_map.crosswalks:
        cw = road_map.crosswalks[0]
        robot_occ = crosswalk_occupancy(trace.states[:, r, :2], trace.bounding_radius_m[r], cw)
        reached = robot_occ > _OCCUPIED
        if reached.any():
            out["p_pedestrian_at_crosswalk"] = float(belief[np.argmax(reached)])
        truth = 0.0
        for p in peds:
            ped_occ = crosswalk_occupancy(trace.states[:, p, :2], trace.bounding_radius_m[p], cw)
            if np.any((ped_occ > _OCCUPIED) & trace.active[:, p]):
                truth = 1.0
        out["brier"] = float(np.nanmean((belief - truth) ** 2))
    return out
