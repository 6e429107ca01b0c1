"""Episode metrics (one module for all of them), computed from a Trace.

Physical metrics of the robot (`robot_0`) with respect to the first pedestrian and the first
crosswalk; belief metrics are added by the robot issue's code from trace.extras.
"""

from __future__ import annotations

import numpy as np

from marl_social.agents.costs import crosswalk_occupancy
from marl_social.dynamics import DT_S
from marl_social.episode import Trace
from marl_social.road_map import RoadMap

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
