"""Stop conditions: end an episode once what it is run to measure is known.

A claim about the time the robot takes to pass the crosswalk is settled the moment it has
passed; one about the robot's belief before it sees the pedestrian, the moment it sees it. Run
on to its step limit, such an episode only adds steps nobody reads. `run_episode(until=...)`
and `record_episode(until=...)` check a condition after every step and end the recording at
the first state where it holds: the trace, and every metric computed from it, is then that of
the steps so far (a metric that looks past that state is not settled).

A condition is the evaluation's, not a planner's: it reads the simulator's truth.
"""

from __future__ import annotations

from marl_social.metrics.physical import PASSED_FRACTION
from marl_social.sim.costs import crosswalk_occupancy


def _base(env):
    return getattr(env, "unwrapped", env)


class PassedCrosswalk:
    """True once an agent's bounding circle has touched the first crosswalk and left it.

    For the robot, the state where it first holds is the one `time_to_pass_s` reports
    (metrics/physical.py: the first state clear of the crosswalk, occupancy <=
    PASSED_FRACTION, after one that touched it); `p_pedestrian_at_crosswalk` is settled
    earlier. Never true on a map without a crosswalk. One instance per episode (it remembers
    the touch).

    Args:
        agent: the agent's name.
    """

    def __init__(self, agent: str = "robot_0"):
        """Start an episode untouched."""
        self.agent = agent
        self._touched = False

    def __call__(self, env) -> bool:
        """Whether the agent has passed, after the env's latest step."""
        base = _base(env)
        crosswalks = base.road_map.crosswalks
        if not crosswalks:
            return False
        i = base.possible_agents.index(self.agent)
        world = base.world
        occupancy = float(crosswalk_occupancy(world.state[i, :2], world.bounding_radius_m[i],
                                              crosswalks[0]))
        self._touched |= occupancy > PASSED_FRACTION
        return self._touched and occupancy <= PASSED_FRACTION


class RobotSees:
    """True once the robot's field of view holds an agent (the trace's `visible` entry).

    Args:
        target: the agent's name, e.g. "pedestrian_0".
        robot: the robot's agent name.
    """

    def __init__(self, target: str, robot: str = "robot_0"):
        """Name the robot and what it must see."""
        self.target, self.robot = target, robot

    def __call__(self, env) -> bool:
        """Whether the robot sees the target after the env's latest step."""
        base = _base(env)
        names = base.possible_agents
        return bool(base.last_fov.visible[names.index(self.robot), names.index(self.target)])
