"""Scenario base: a frozen parameter dataclass with validated overrides, and a layout builder.

The builder turns parameters (and the episode's generator) into a layout: the static map and
the agents.

A new scenario is small: subclass `ScenarioParams` with its own fields and checks, subclass
`Scenario` with `name`, `params_cls` and `build`, and register it in `marl_social.scenarios`.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from marl_social.agents.registry import ROBOT_PLANNERS
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.road_map import RoadMap


@dataclass(frozen=True)
class ScenarioParams:
    """Parameters every scenario has.

    Attributes:
        n_slots: object slots K in every observation.
        n_rays: depth rays per observation (visibility polygon).
        terminate_on_collision: if True any collision ends the episode for every agent; if
            False only the agents involved are terminated.
        collision_penalty: reward subtracted from each agent involved in a collision.
        robot_planner: the robot's built-in planner, a name of
            `marl_social.agents.registry.ROBOT_PLANNERS`: "social" (the paper), "social+beta"
            (also infers each human's rationality), "aggressive", "conservative", "oracle"
            (agents/robot/planner.py) or "cruise" (the rule-based baseline, agents/cruise.py).
    """

    n_slots: int = 8
    n_rays: int = 32
    terminate_on_collision: bool = True
    collision_penalty: float = 100.0
    robot_planner: str = "social"

    def __post_init__(self):
        self._check(self.robot_planner in ROBOT_PLANNERS, "robot_planner",
                    f"must be one of {ROBOT_PLANNERS}")
        self._check(self.n_slots >= 1, "n_slots", "must be >= 1")
        self._check(self.n_rays >= 1, "n_rays", "must be >= 1")
        self._check(self.collision_penalty >= 0, "collision_penalty", "must be >= 0")

    def _check(self, ok: bool, field_name: str, message: str) -> None:
        if not ok:
            raise ValueError(f"{type(self).__name__}.{field_name}={getattr(self, field_name)!r}: "
                             f"{message}")


def make_params(params_cls: type[ScenarioParams], overrides: dict) -> ScenarioParams:
    """Build params from overrides, rejecting unknown keys and values of the wrong type."""
    fields = {f.name: f for f in dataclasses.fields(params_cls)}
    unknown = sorted(set(overrides) - set(fields))
    if unknown:
        raise ValueError(f"unknown scenario parameter(s) {unknown} for {params_cls.__name__}; "
                         f"valid: {sorted(fields)}")
    clean = {}
    for key, value in overrides.items():
        default = getattr(params_cls, key, None)
        if isinstance(default, bool):
            if not isinstance(value, (bool, np.bool_)):
                raise TypeError(f"{params_cls.__name__}.{key}: expected a bool, got {value!r}")
            value = bool(value)
        elif isinstance(default, int):
            if isinstance(value, bool) or not float(value).is_integer():
                raise ValueError(f"{params_cls.__name__}.{key}: expected an integer, got {value!r}")
            value = int(value)
        elif isinstance(default, float):
            if isinstance(value, bool):
                raise TypeError(f"{params_cls.__name__}.{key}: expected a number, got {value!r}")
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise ValueError(
                    f"{params_cls.__name__}.{key}: expected a number, got {value!r}"
                ) from None
            if np.isnan(value):
                raise ValueError(f"{params_cls.__name__}.{key}: NaN is not a valid value")
        clean[key] = value
    return params_cls(**clean)


@dataclass(frozen=True)
class ScenarioLayout:
    """What a scenario builds for one episode."""

    road_map: RoadMap
    agents: tuple[AgentSpec, ...]
    params: ScenarioParams


class Scenario(ABC):
    """A scenario: name, parameter class and layout builder."""

    name: str = ""
    params_cls: type[ScenarioParams] = ScenarioParams
    # representative parameter sets, one per behaviour the scenario shows (the API tests run
    # each of them)
    variants: tuple[dict, ...] = ({},)

    def __init__(self, **overrides):
        self.params = make_params(self.params_cls, overrides)

    @abstractmethod
    def build(self, rng: np.random.Generator) -> ScenarioLayout:
        """The layout for one episode. The agent names and kinds must not depend on rng."""
