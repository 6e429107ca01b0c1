"""Built-in policies for every agent of an env.

    policies = marl_social.policies(env)       # {agent: policy}; policy(obs) -> action

Every policy comes from the planner registry (agents/registry.py) and is built from its agent's
spec (its own parameters), the shared observation layout and the static map with only its own
route (`RoadMap.for_agent`); it never receives the env, the world, the other agents' names or
their routes, so that it learns who else exists only from its observation. Only a policy with `needs_truth` (the oracle) is also handed
`truth_tracks(env, agent)` before each step, by its caller.
"""

from __future__ import annotations

import numpy as np

from marl_social.agents.base import Policy
from marl_social.agents.registry import DEFAULT_PLANNER, build_planner
from marl_social.perception.tracking import TrackSet
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.observation import ObservationLayout
from marl_social.sim.road_map import RoadMap


def make_policy(spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap,
                agent_names: list[str], robot_planner: str = "social") -> Policy:
    """The built-in planner of one agent, from the planner registry.

    Humans and pedestrians run their role's DEFAULT_PLANNER (Boltzmann planners); the robot
    runs `robot_planner` (one of agents.registry.ROBOT_PLANNERS). The planner gets
    `road_map.for_agent(spec.name)` and only its own name as the agent names: what it knows of
    the others comes from its observations.

    Args:
        spec: the agent's own AgentSpec.
        layout: the shared observation layout.
        road_map: the static map (the other agents' routes are removed before the planner
            sees it).
        agent_names: the env's possible_agents; only checked to contain spec.name, never
            passed on.
        robot_planner: the robot's planner name.

    Raises:
        ValueError: an unknown planner or a bad planner parameter, naming the agent.
    """
    if spec.name not in agent_names:
        raise ValueError(f"agent {spec.name!r}: not one of the env's agents {list(agent_names)}")
    name = robot_planner if spec.role == "robot" else DEFAULT_PLANNER[spec.role]
    return build_planner(name, spec, layout, road_map.for_agent(spec.name), (spec.name,))


def policies(env) -> dict[str, Policy]:
    """{agent: policy} for every possible agent of a SocialDrivingEnv (or a wrapper of one).

    The robot's planner is the scenario's `robot_planner` parameter.
    """
    base = getattr(env, "unwrapped", env)
    mode = base.scenario.params.robot_planner
    return {name: make_policy(spec, base.obs_layout, base.road_map, base.possible_agents, mode)
            for name, spec in base.agent_specs.items()}


def truth_tracks(env, observer: str) -> TrackSet:
    """The true current state of every other active agent as a TrackSet.

    The privileged input of a planner with `needs_truth` (the oracle); no other planner
    receives it.

    Args:
        env: a SocialDrivingEnv (or a wrapper of one).
        observer: the agent whose others are listed.
    """
    base = getattr(env, "unwrapped", env)
    world = base.world
    i = base.possible_agents.index(observer)
    others = np.flatnonzero(world.active & (np.arange(world.n) != i))
    return TrackSet(
        ids=others + 1, xy=world.state[others, :2].copy(),
        velocity=world.velocity_mps[others].copy(), pos_std_m=np.zeros(len(others)),
        length_m=world.length_m[others], width_m=world.width_m[others],
        is_pedestrian=world.is_pedestrian[others], seen=np.ones(len(others), bool),
        age_unseen_s=np.zeros(len(others)), heading_rad=world.state[others, 2].copy(),
    )


def truth_signal_phase(env) -> int | None:
    """The signal plan's running phase (index into RoadMap.signal_plan.phases); None: no signals.

    The privileged input of a planner with `needs_truth`, with `truth_tracks`.

    Args:
        env: a SocialDrivingEnv (or a wrapper of one).
    """
    world = getattr(env, "unwrapped", env).world
    if world.signals is None:
        return None
    return int(world.signals.phase_at(world.time_s))
