"""The planner registry: planner name -> policy factory and typed parameters.

    policy = build_planner("social", spec, layout, road_map, agent_names)

Each entry names the roles that may use it, the frozen dataclass its parameters are parsed
into from `AgentSpec.planner` (agents/params.py: unknown keys and bad values are errors naming
the agent and the field) and the factory that builds the policy from the agent's spec, the
shared observation layout, the static map and the env's agent names — never the env.

Built-in planners:

* the robot's: "social", "social+beta", "aggressive", "conservative", "oracle" (the contingency
  MPC, agents/robot/planner.py, one `RobotVariant` each) and "cruise" (the rule-based
  baseline, agents/cruise.py). `ROBOT_PLANNERS` is the one list of their names.
* "boltzmann_driver" (agents/human.py) for the human drivers and "boltzmann_pedestrian"
  (agents/pedestrian.py) for the pedestrians; `DEFAULT_PLANNER` maps a role to its planner.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, fields
from typing import Any

from marl_social.agents.base import Policy
from marl_social.agents.cruise import CruiseVehiclePolicy
from marl_social.agents.human import BoltzmannDriver
from marl_social.agents.params import (
    DriverParams,
    NoPlannerParams,
    PedestrianPlannerParams,
    RobotModelParams,
    parse_planner_params,
)
from marl_social.agents.pedestrian import BoltzmannPedestrian
from marl_social.agents.robot.variants import ROBOT_VARIANTS
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.observation import ObservationLayout
from marl_social.sim.road_map import RoadMap

# factory(spec, params, layout, road_map, agent_names) -> policy
PolicyFactory = Callable[[AgentSpec, Any, ObservationLayout, RoadMap, Sequence[str]], Policy]


@dataclass(frozen=True)
class PlannerEntry:
    """One registered planner.

    Attributes:
        name: the planner's name (a scenario's `robot_planner` value for a robot planner).
        roles: the agent roles that may use it ("robot", "human", "pedestrian").
        params_cls: the frozen dataclass its parameters are parsed into (agents/params.py).
        factory: builds the policy from (spec, params, layout, road_map, agent_names).
        ignored_keys: keys of AgentSpec.planner that may be present but that it does not read.
    """

    name: str
    roles: tuple[str, ...]
    params_cls: type
    factory: PolicyFactory
    ignored_keys: tuple[str, ...] = ()


PLANNERS: dict[str, PlannerEntry] = {}


def register_planner(entry: PlannerEntry) -> PlannerEntry:
    """Add `entry` to PLANNERS under its name (a name may be registered once)."""
    if entry.name in PLANNERS:
        raise ValueError(f"planner {entry.name!r} is already registered")
    PLANNERS[entry.name] = entry
    return entry


def _robot_factory(variant_name: str) -> PolicyFactory:
    def build(spec, params, layout, road_map, agent_names):
        # imported at the first robot planner built: the MPC's QP solvers take ~0.5 s to import
        from marl_social.agents.robot.planner import RobotPlanner
        from marl_social.agents.robot.settings import RobotSettings

        return RobotPlanner(spec, layout, road_map, list(agent_names),
                            RobotSettings(planner=variant_name, model=params))
    return build


for _name in ROBOT_VARIANTS:
    register_planner(PlannerEntry(_name, ("robot",), RobotModelParams, _robot_factory(_name)))
register_planner(PlannerEntry(
    "cruise", ("robot",), NoPlannerParams,
    lambda spec, params, layout, road_map, agent_names: CruiseVehiclePolicy(
        spec, layout, road_map),
    # the robot's model of the humans: the rule-based baseline has none
    ignored_keys=tuple(f.name for f in fields(RobotModelParams)),
))
register_planner(PlannerEntry(
    "boltzmann_driver", ("human",), DriverParams,
    lambda spec, params, layout, road_map, agent_names: BoltzmannDriver(
        spec, layout, road_map, params),
))
register_planner(PlannerEntry(
    "boltzmann_pedestrian", ("pedestrian",), PedestrianPlannerParams,
    lambda spec, params, layout, road_map, agent_names: BoltzmannPedestrian(
        spec, layout, road_map, params),
))

ROBOT_PLANNERS: tuple[str, ...] = tuple(n for n, e in PLANNERS.items() if "robot" in e.roles)
DEFAULT_PLANNER: dict[str, str] = {"human": "boltzmann_driver",
                                   "pedestrian": "boltzmann_pedestrian"}


def planner_entry(name: str, spec: AgentSpec) -> PlannerEntry:
    """The registered planner `name` for agent `spec`.

    Args:
        name: a registered planner name.
        spec: the agent that is to run it (its role must be one of the entry's roles).

    Raises:
        ValueError: an unknown name or one not for the agent's role, naming the agent.
    """
    entry = PLANNERS.get(name)
    if entry is None or spec.role not in entry.roles:
        valid = [n for n, e in PLANNERS.items() if spec.role in e.roles]
        raise ValueError(f"agent {spec.name!r}: unknown planner {name!r} for role "
                         f"{spec.role!r}; valid: {valid}")
    return entry


def planner_params(name: str, spec: AgentSpec):
    """The typed, validated parameters of planner `name` from `spec.planner`.

    Args:
        name: a registered planner name.
        spec: the agent (its `planner` dict is parsed; its name is in every error).
    """
    entry = planner_entry(name, spec)
    return parse_planner_params(entry.params_cls, spec, entry.ignored_keys)


def build_planner(name: str, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap,
                  agent_names: Sequence[str]) -> Policy:
    """A new policy of planner `name` for agent `spec`.

    Args:
        name: a registered planner name valid for the agent's role.
        spec: the agent's own AgentSpec.
        layout: the shared observation layout.
        road_map: the static map.
        agent_names: the env's possible_agents (the robot's belief maps ids to names).

    Raises:
        ValueError: an unknown planner, or a bad planner parameter, naming the agent.
    """
    entry = planner_entry(name, spec)
    params = parse_planner_params(entry.params_cls, spec, entry.ignored_keys)
    return entry.factory(spec, params, layout, road_map, agent_names)
