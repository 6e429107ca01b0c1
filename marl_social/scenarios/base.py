"""Scenario base: a frozen parameter dataclass with validated overrides, and a layout builder.

The builder turns parameters (and the episode's generator) into a layout: the static map and
the agents.

A new scenario is small: subclass `ScenarioParams` with its own fields and checks, subclass
`Scenario` with `name`, `params_cls` and `build`, and register it in `marl_social.scenarios`.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from marl_social.agents.registry import ROBOT_PLANNERS
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.costs import CostWeights
from marl_social.sim.road_map import RoadMap
from marl_social.sim.signals import SignalController

MAX_SLOTS = 64  # largest observation slot count K
MAX_RAYS = 1024  # largest depth ray count per observation
MAX_COST_WEIGHT = 1e6  # largest |cost weight| of a human or of the robot's model of one
MAX_COLLISION_PENALTY = 1e9  # largest collision penalty (finite: inf * False is NaN)
FLOAT_MAX = float(np.finfo(np.float64).max)
# physical limits of the scenarios' parameters
MAX_VEHICLE_SPEED_MPS = 20.0  # largest allowed initial / desired car speed [m/s]
MAX_SENSOR_RANGE_M = 1000.0  # longest sensor range [m]
MAX_POS_NOISE_M = 10.0  # largest measurement noise std [m]
MAX_SPEED_LIMIT_MPS = 50.0  # highest legal speed limit [m/s]  # a Python float: compares exactly with any int
# theta_R: the robot values comfort more than the default driver model (smooth, early braking)
THETA_ROBOT = CostWeights(accel=0.5, jerk=0.5)


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
        robot_stage_settings: the settings tree's robot.<part>.<field> leaves as (part, field,
            value) triples (agents/robot/settings.STAGE_PARTS), handed to the robot's planner.
    """

    n_slots: int = 8
    n_rays: int = 32
    terminate_on_collision: bool = True
    collision_penalty: float = 100.0
    robot_planner: str = "social"
    robot_stage_settings: tuple = ()

    def __post_init__(self):
        self._check_types()
        self._check(self.robot_planner in ROBOT_PLANNERS, "robot_planner",
                    f"must be one of {ROBOT_PLANNERS}")
        self._check_range("n_slots", 1, MAX_SLOTS)
        self._check_range("n_rays", 1, MAX_RAYS)
        self._check_range("collision_penalty", 0.0, MAX_COLLISION_PENALTY)
        if self.robot_stage_settings:
            from marl_social.agents.robot.settings import checked_stage_settings

            object.__setattr__(self, "robot_stage_settings",
                               checked_stage_settings(self.robot_stage_settings))

    def _check(self, ok: bool, field_name: str, message: str) -> None:
        if not ok:
            raise ValueError(f"{type(self).__name__}.{field_name}="
                             f"{short_repr(getattr(self, field_name))}: {message}")

    def _check_range(self, field_name: str, low: float, high: float, unit: str = "",
                     low_open: bool = False, allow_inf: bool = False) -> None:
        """Check low <= value <= high (low < value if low_open), finite unless allow_inf."""
        value = getattr(self, field_name)
        suffix = f" {unit}" if unit else ""
        if not allow_inf and not isinstance(value, (int, np.integer)):  # big ints are finite
            self._check(math.isfinite(value), field_name, "must be finite")
        ok = (value > low if low_open else value >= low) and (value <= high or (
            allow_inf and value == math.inf))
        bracket = "(" if low_open else "["
        upper = f"{high:g}" + (" or inf" if allow_inf else "")
        self._check(ok, field_name, f"must be in {bracket}{low:g}, {upper}]{suffix}")

    def _normalize_cost_weights(self, field_name: str, fit_file: bool = False) -> None:
        """Store a cost-weights field as 6 numbers (FEATURE_NAMES order), () for the default.

        Accepts (), None, a mapping of feature names or 6 numbers; with `fit_file` also the
        path of a `marl-social irl fit` result (its direction at the default weights' norm,
        agents/irl.robot_model_from_fit; an empty path means the default). A bad value or
        file is a ValueError naming the field.
        """
        value = getattr(self, field_name)
        where = f"{type(self).__name__}.{field_name}"
        if fit_file and isinstance(value, (str, Path)):
            from marl_social.agents.irl.laplace import load_fit, robot_model_from_fit

            if not str(value).strip():
                value = ()
            else:
                try:
                    model, _ = robot_model_from_fit(load_fit(value))
                except (OSError, ValueError) as err:
                    raise ValueError(f"{where}: {err}") from None
                value = tuple(model.as_array().tolist())
        if not isinstance(value, (Mapping, CostWeights)):
            value = as_vector(value, where)
            if not value:
                object.__setattr__(self, field_name, ())
                return
        try:
            theta = CostWeights.from_any(value).as_array()
        except (TypeError, ValueError) as err:
            raise ValueError(f"{where}: {err}") from None
        if not np.all(np.isfinite(theta)) or np.max(np.abs(theta)) > MAX_COST_WEIGHT:
            raise ValueError(f"{where}: cost weights must be finite and within "
                             f"+-{MAX_COST_WEIGHT:g}, got {short_repr(theta.tolist())}")
        object.__setattr__(self, field_name, tuple(theta.tolist()))

    def _check_types(self) -> None:
        """Every bool, int and float field holds a value of its type (float fields: no NaN)."""
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            default = f.default
            if isinstance(default, bool):
                ok = isinstance(value, (bool, np.bool_))
                kind = "a bool"
            elif isinstance(default, int):
                ok = isinstance(value, (int, np.integer)) and not isinstance(value, (bool,
                                                                                     np.bool_))
                kind = "an integer"
            elif isinstance(default, float):
                ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
                    value, (bool, np.bool_))
                kind = "a real number"
                if ok and isinstance(value, (int, np.integer)):
                    self._check(abs(int(value)) <= FLOAT_MAX, f.name, "is beyond float range")
                if ok:
                    self._check(not math.isnan(value), f.name, "NaN is not a valid value")
            else:
                continue
            if not ok:
                raise TypeError(f"{type(self).__name__}.{f.name}={short_repr(value)}: expected "
                                f"{kind}, got {type(value).__name__}")


def short_repr(value, limit: int = 60) -> str:
    """repr(value) cut to `limit` characters (the repr of 10**400 is 401 characters)."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


def as_integer(value, name: str) -> int:
    """An integral value (int, integral float or numeric string) as int, else an error.

    A bool is a TypeError; anything else not integral a ValueError; both name the field.

    Args:
        value: the value to convert.
        name: the field's name for the message (e.g. "OccludedCrosswalkParams.n_humans").
    """
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected an integer, got {value!r}")
    if isinstance(value, (int, np.integer)):
        return int(value)
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name}: expected an integer, got {short_repr(value)}") from None
    if not number.is_integer():
        raise ValueError(f"{name}: expected an integer, got {short_repr(value)}")
    return int(number)


def as_vector(value, name: str) -> tuple[float, ...]:
    """A vector-valued setting as a tuple of floats, else a one-line ValueError naming it.

    The one rule for such settings: a list, tuple or 1-d numpy array of real numbers (None:
    empty).

    Args:
        value: the value to convert.
        name: the field's name for the message.
    """
    if value is None:
        return ()
    if not isinstance(value, (list, tuple, np.ndarray)):  # one error type for a bad setting
        raise ValueError(  # noqa: TRY004
            f"{name}: expected a list or array of numbers, got {short_repr(value)} "
            f"({type(value).__name__})")
    items = np.asarray(value, dtype=object).ravel()
    if any(isinstance(v, (bool, np.bool_, str, bytes)) for v in items):
        raise ValueError(f"{name}: expected numbers, got {short_repr(value)}")
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name}: expected real numbers, got {short_repr(value)}") from None
    if array.ndim != 1:
        raise ValueError(f"{name}: expected a flat list of numbers, got shape {array.shape}")
    return tuple(array.tolist())


def as_real(value, name: str) -> float:
    """A real number (or numeric string) as float: NaN and beyond float range are ValueErrors.

    Args:
        value: the value to convert.
        name: the field's name for the message.
    """
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected a number, got {value!r}")
    try:
        number = float(value)
    except OverflowError:
        raise ValueError(f"{name}: {short_repr(value)} is beyond float range") from None
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number, got {short_repr(value)}") from None
    if math.isnan(number):
        raise ValueError(f"{name}: NaN is not a valid value")
    return number


# settings-tree prefixes of the parameters every scenario has (the others by their own prefix)
_BASE_LEAVES = {"n_slots": "env.n_slots", "n_rays": "env.n_rays",
                "terminate_on_collision": "env.terminate_on_collision",
                "collision_penalty": "env.collision_penalty", "robot_planner": "robot.planner"}
_AGENT_PREFIXES = ("human_", "pedestrian_", "robot_")


def dotted_name(field_name: str) -> str:
    """A scenario parameter's name in the settings tree (its layout knobs keep their name).

    env.* for the env's settings, human.* / pedestrian.* / robot.* for each agent kind's
    (human_beta -> human.beta, robot_epsilon -> robot.epsilon), the rest as it is.
    """
    if field_name in _BASE_LEAVES:
        return _BASE_LEAVES[field_name]
    for prefix in _AGENT_PREFIXES:
        if field_name.startswith(prefix):
            return prefix[:-1] + "." + field_name[len(prefix):]
    return field_name


def flat_overrides(params_cls: type[ScenarioParams], overrides: dict) -> dict:
    """Overrides keyed by settings-tree names (or the flat field names) as field names.

    A robot.<part>.<field> leaf of the robot's parts (agents/robot/settings.STAGE_PARTS)
    joins robot_stage_settings.

    Args:
        params_cls: the scenario's parameter dataclass.
        overrides: {dotted or flat name: value}.

    Raises:
        ValueError: a name that is no setting of this scenario, with the closest one.
    """
    fields = [f.name for f in dataclasses.fields(params_cls) if f.name != "robot_stage_settings"]
    by_dotted = {dotted_name(f): f for f in fields}
    flat: dict = {}
    stage: list = []
    for key, value in overrides.items():
        if key in by_dotted or key == "robot_stage_settings":
            flat[by_dotted.get(key, key)] = value
        elif key in fields:
            flat[key] = value
        elif isinstance(key, str) and key.startswith("robot.") and key.count(".") == 2:
            _, part, name = key.split(".")
            stage.append((part, name, value))
        else:
            close = difflib.get_close_matches(str(key), list(by_dotted) + fields, n=1,
                                              cutoff=0.6)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ValueError(f"unknown scenario parameter {short_repr(key)} for "
                             f"{params_cls.__name__}{hint}; valid: {sorted(by_dotted)} and "
                             "robot.<part>.<field> (`marl-social params` lists them)")
    if stage:
        flat["robot_stage_settings"] = tuple(flat.get("robot_stage_settings", ())) + tuple(stage)
    return flat


def setting_value(params: ScenarioParams, name: str):
    """The value `params` holds for a setting given by its field or settings-tree name.

    Raises:
        KeyError: a name that is no setting of these parameters.
    """
    if hasattr(params, name):
        return getattr(params, name)
    flat = flat_overrides(type(params), {name: None})
    if "robot_stage_settings" in flat:
        _, part, field_name = name.split(".")
        for p, f, value in reversed(params.robot_stage_settings):  # the last one set wins
            if (p, f) == (part, field_name):
                return value
        raise KeyError(name)
    return getattr(params, next(iter(flat)))


def make_params(params_cls: type[ScenarioParams], overrides: dict) -> ScenarioParams:
    """Build params from overrides, rejecting unknown keys and values of the wrong type.

    Args:
        params_cls: the scenario's parameter dataclass.
        overrides: {settings-tree name or field name: value}; numbers may be numeric strings
            ("10", "2.5").
    """
    overrides = flat_overrides(params_cls, overrides)
    clean = {}
    for key, value in overrides.items():
        default = getattr(params_cls, key, None)
        name = f"{params_cls.__name__}.{key}"
        if isinstance(default, bool):
            if not isinstance(value, (bool, np.bool_)):
                raise TypeError(f"{name}: expected a bool, got {short_repr(value)}")
            value = bool(value)
        elif isinstance(default, int):
            value = as_integer(value, name)
        elif isinstance(default, float):
            value = as_real(value, name)
        clean[key] = value
    return params_cls(**clean)


@dataclass(frozen=True)
class ScenarioLayout:
    """What a scenario builds for one episode.

    Attributes:
        road_map: the static map.
        agents: every agent's spec.
        params: the scenario's parameters.
        signals: the signal controller's clock (the world's signal state; None: no signals).
    """

    road_map: RoadMap
    agents: tuple[AgentSpec, ...]
    params: ScenarioParams
    signals: SignalController | None = None


@dataclass(frozen=True)
class HiddenAgent:
    """What a scene hides from the robot, and the same episode without it (the counterfactual).

    Attributes:
        names: the agents the robot cannot see at first (its first sight of one reveals what is
            hidden); () where what is hidden is no agent (a signal phase the robot cannot read).
        absent: the scenario overrides of the counterfactual episode: the hidden agent removed
            (or the hidden state the other way round).
        belief: the trace extra of the robot's belief in it (evaluation/run.EpisodeResult).
    """

    names: tuple[str, ...]
    absent: dict
    belief: str


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

    def hidden_agent(self) -> HiddenAgent | None:
        """What this episode hides from the robot and how to run it without (None: nothing).

        The hidden agents come last among the agents, so that removing them shifts no other
        agent's index (its policy's seed, evaluation/rollout.record_episode).
        """
        return None
