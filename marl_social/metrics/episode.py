"""The two metric sets of an episode, computed from the registry.

`episode_metrics`: physical metrics of the robot (`marl_social.metrics.physical`);
`belief_metrics`: the robot's belief in a crossing pedestrian (`marl_social.metrics.belief`).
`run_episode` returns both, in this order.
"""

from __future__ import annotations

from marl_social.metrics.belief import BELIEF_CONFIDENT, HUMAN_BRAKE_MPS2
from marl_social.metrics.physical import HARD_BRAKE_MPS2
from marl_social.metrics.registry import MetricValue, compute_metrics, metric_names
from marl_social.sim.road_map import RoadMap
from marl_social.sim.trace import Trace

__all__ = ["BELIEF_CONFIDENT", "HARD_BRAKE_MPS2", "HUMAN_BRAKE_MPS2", "belief_metrics",
           "episode_metrics"]


def episode_metrics(trace: Trace, road_map: RoadMap,
                    robot: str = "robot_0") -> dict[str, MetricValue]:
    """Physical metrics of one episode (the registry's group "episode").

    Args:
        trace: the episode's finalized trace.
        road_map: the episode's static map.
        robot: name of the robot.

    Returns:
        A dict of floats / bools, in this order:
        collision: any agent touched anything.
        robot_collision: the robot touched anything.
        mean_speed_mps, min_speed_mps: robot speeds while active [m/s].
        max_decel_mps2: largest braking of the robot [m/s^2] (>= 0).
        max_jerk_mps3: largest |change of robot acceleration| / dt [m/s^3].
        min_gap_pedestrian_m: smallest centre distance robot-pedestrian minus both bounding
            radii [m], >= 0 (nan without pedestrian or crosswalk; conservative for the car's
            long sides).
        yielded: the robot was never in the crosswalk while the pedestrian was in it, and
            never in a conflict zone on its route, where it yields, that an agent with the
            right of way reached within physical.YIELD_WINDOW_S or was in behind the robot.
        time_to_pass_s: time until the robot's footprint (bounding circle) has entered and left
            the scenario's conflict area [s]: the crosswalk, or on a map without one every
            conflict zone on its route (nan if never).
        others_max_decel_mps2: hardest braking the robot forced on a human driver [m/s^2]
            (>= 0): braking while the robot was the nearest agent in the human's way
            (physical.others_max_decel).
        hard_brake: max_decel > HARD_BRAKE_MPS2.
    """
    return compute_metrics(trace, road_map, robot, metric_names("episode"))


def belief_metrics(trace: Trace, road_map: RoadMap,
                   robot: str = "robot_0") -> dict[str, MetricValue]:
    """Metrics of the robot's belief in a crossing pedestrian (the registry's group "belief").

    The belief is trace.extras["p_pedestrian"], (T+1,); nan where the trace has no belief or
    no pedestrian.

    Args:
        trace: the episode's finalized trace.
        road_map: the episode's static map.
        robot: name of the robot.

    Returns:
        A dict of floats / bools, in this order:
        robot_first_sees_pedestrian_s: first time the robot sees a pedestrian [s].
        p_pedestrian_before_seen: belief at the last step before the robot first sees it.
        brake_to_confident_s: from the first human's braking onset to belief > BELIEF_CONFIDENT
            [s] (nan if either never happens).
        p_pedestrian_at_crosswalk: belief when the robot's footprint first reaches the crosswalk.
        max_p_pedestrian_unseen: largest belief while no pedestrian is visible to the robot.
        brier: mean squared error of the belief against the truth (a pedestrian that enters the
            crosswalk during the episode = 1).
        belief_confident_before_seen: belief exceeded BELIEF_CONFIDENT before the robot saw it.
    """
    return compute_metrics(trace, road_map, robot, metric_names("belief"))
