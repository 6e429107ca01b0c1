"""Typed planner parameters: frozen dataclasses parsed and validated from `AgentSpec.planner`.

Every built-in planner reads its agent's private parameters (`AgentSpec.planner`, a plain dict
set by the scenario) through one of these classes, never with `dict.get`. `parse_planner_params`
rejects unknown keys, values of the wrong type and values out of range, naming the agent and the
field:

    agent 'human_0': planner parameter beta=-1.0: must be >= 0
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, ClassVar, TypeVar

import numpy as np

from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.costs import CostWeights

P = TypeVar("P")


def _nonnegative(value: float) -> bool:
    return value >= 0.0  # False for NaN


@dataclass(frozen=True)
class NoPlannerParams:
    """A planner that reads no parameter from its agent's spec (the rule-based cruise car)."""

    CHECKS: ClassVar[tuple] = ()


@dataclass(frozen=True)
class DriverParams:
    """A Boltzmann human driver's parameters (agents/human.py).

    Attributes:
        beta: rationality of the Boltzmann choice (eq. 8) [1/cost]; inf = argmin, 0 = uniform.
        expects_yield: it expects a car that must give way in a conflict zone ahead of it to
            stop before the zone if it can at a comfortable deceleration
            (models/yield_expectation.py); False (the default): every other vehicle at
            constant velocity.
    """

    beta: float = 5.0
    expects_yield: bool = False

    CHECKS: ClassVar[tuple] = (("beta", _nonnegative, "must be >= 0"),)


@dataclass(frozen=True)
class PedestrianPlannerParams:
    """A pedestrian's parameters (agents/pedestrian.py and the cruise pedestrian).

    Attributes:
        crossing: whether it intends to cross.
        start_delay_s: when that intent begins, from the episode start [s].
        beta: rationality of the Boltzmann choice [1/cost] (the cruise pedestrian ignores it).
    """

    crossing: bool = True
    start_delay_s: float = 0.0
    beta: float = 5.0

    CHECKS: ClassVar[tuple] = (
        ("start_delay_s", _nonnegative, "must be >= 0"),
        ("beta", _nonnegative, "must be >= 0"),
    )


@dataclass(frozen=True)
class RobotModelParams:
    """The robot's private model of the humans (the contingency-MPC planners, agents/robot/).

    Attributes:
        theta_hat: cost weights it assumes for the humans (None: BeliefConfig's default).
        beta_hat: the humans' rationality it assumes [1/cost] (None: BeliefConfig's default).
        epsilon: tail threshold on beliefs, in [0, 1) (None: BeliefConfig's default).
        human_expects_yield: it assumes the humans expect a car that must give way to stop
            before the zone if it comfortably can (BeliefConfig.human_expects_yield).
        sight_hold: pulling out of a stop sign, it holds short of a lane it cannot see while
            a hidden car may come and a human that will tell is still coming
            (agents/robot/sight_hold.py; the intersection scenarios' knob robot_sight_hold,
            on by default there).
        stage_settings: (part, field, value) triples, the settings tree's robot.<part>.<field>
            leaves (agents/robot/settings.STAGE_PARTS: mpc, belief, curb, ...), applied over
            the parts' defaults when the robot is built.
    """

    theta_hat: CostWeights | None = None
    beta_hat: float | None = None
    epsilon: float | None = None
    human_expects_yield: bool = False
    sight_hold: bool = False
    stage_settings: tuple = ()

    CHECKS: ClassVar[tuple] = (
        ("beta_hat", _nonnegative, "must be >= 0"),
        ("epsilon", lambda e: 0.0 <= e < 1.0, "must be in [0, 1)"),
    )


def _fail(spec: AgentSpec, key: str, value: Any, message: str) -> ValueError:
    return ValueError(f"agent {spec.name!r}: planner parameter {key}={value!r}: {message}")


def _coerce(spec: AgentSpec, key: str, value: Any, default: Any) -> Any:
    """The value converted to the type of the field's default (float, bool or CostWeights)."""
    if isinstance(default, bool):
        if not isinstance(value, (bool, np.bool_)):
            raise _fail(spec, key, value, "expected a bool")
        return bool(value)
    if isinstance(default, tuple):  # stage_settings: (part, field, value) triples
        if not (isinstance(value, (tuple, list))
                and all(isinstance(v, (tuple, list)) and len(v) == 3 for v in value)):
            raise _fail(spec, key, value, "expected (part, field, value) triples")
        return tuple(tuple(v) for v in value)
    if key == "theta_hat":
        try:
            return CostWeights.from_any(value)
        except (TypeError, ValueError) as err:
            raise _fail(spec, key, value, f"expected cost weights ({err})") from None
    if isinstance(value, (bool, np.bool_)):
        raise _fail(spec, key, value, "expected a number")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise _fail(spec, key, value, "expected a number") from None
    if math.isnan(number):
        raise _fail(spec, key, value, "NaN is not a valid value")
    return number


def parse_planner_params(params_cls: type[P], spec: AgentSpec,
                         ignored_keys: Iterable[str] = ()) -> P:
    """The agent's planner parameters as a `params_cls` instance, validated.

    Args:
        params_cls: a frozen dataclass of this module (fields with defaults, and CHECKS: a
            tuple of (field, predicate, message) applied to every value that is not None).
        spec: the agent whose `planner` dict is parsed; its name is in every error.
        ignored_keys: keys that may be present but that this planner does not read.

    Returns:
        The parameters: the spec's values where given, the class defaults elsewhere.

    Raises:
        ValueError: an unknown key, a value of the wrong type or out of range, naming the
            agent and the field.
    """
    fields = {f.name: f for f in dataclasses.fields(params_cls)}
    given = {k: v for k, v in spec.planner.items() if k not in set(ignored_keys)}
    unknown = sorted(set(given) - set(fields))
    if unknown:
        raise ValueError(f"agent {spec.name!r}: unknown planner parameter(s) {unknown} for "
                         f"{params_cls.__name__}; known: {sorted(fields)}")
    values = {k: _coerce(spec, k, v, fields[k].default) for k, v in given.items()}
    checks: tuple[tuple[str, Callable[[Any], bool], str], ...] = params_cls.CHECKS
    for key, ok, message in checks:
        if values.get(key) is not None and not ok(values[key]):
            raise _fail(spec, key, given[key], message)
    return params_cls(**values)
