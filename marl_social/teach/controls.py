"""The page's controls, each bound to a settings-tree leaf, and the check of what a page sends.

A control's name is its leaf's dotted name (`human.beta`, `robot.planner`, ...; `marl-social
params SCENARIO` lists them), so what a student sets in the page is what `--set` sets on the
command line. Two controls are not leaves: `scenario` (the scene) and `seed`. A request is
checked here (known control, value of the right type and inside the control's range) and then
by the scenario's own parameter validation (`scenarios.base.make_params`); any failure is one
line (`SettingsError`) the page shows.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass

from marl_social.agents.registry import ROBOT_PLANNERS
from marl_social.scenarios import SCENARIOS
from marl_social.scenarios.base import make_params
from marl_social.scenarios.settings_tree import settings_leaves
from marl_social.sim.seeds import checked_seed

# the robot's model of the humans' cost weights, in marl_social.sim.costs.FEATURE_NAMES order
# (tracking, speed, accel, jerk, safety, crosswalk); "true": the humans' own (the default
# CostWeights); "learned": the direction fitted by inverse optimal control (agents/irl/laplace
# fit_theta on 100 near-rational demonstrations at 10 x the true weights, seed 11, scaled by
# robot_model_from_fit; tests/teach/test_controls.py refits it); "wrong": a robot that thinks
# humans hardly weigh the crosswalk (tutorial 02, "a wrong model of the human")
THETA_HAT_PRESETS: dict[str, tuple[float, ...]] = {
    "true": (),
    "learned": (1.0, 0.98647, 0.09922, 0.09919, 1.10348, 999.99990),
    "wrong": (1.0, 1.0, 0.2, 0.2, 1.0, 1.0),
}
VARIANT_LEAVES = ("pedestrian", "hidden_vehicle", "phase")  # a scene's named variants
MAX_SEED = 2**31 - 1


class SettingsError(ValueError):
    """A page's request the app cannot run: one line saying which control and why."""


@dataclass(frozen=True)
class Control:
    """One control of the page.

    Attributes:
        name: its settings-tree leaf ("scenario" and "seed": not leaves).
        kind: "choice", "float", "int" or "bool".
        label: what the page calls it.
        options: the values of a choice.
        low: the smallest value of a number.
        high: the largest value of a number.
        step: a slider's step.
        default: the value it starts at.
    """

    name: str
    kind: str
    label: str
    options: tuple = ()
    low: float = 0.0
    high: float = 0.0
    step: float = 1.0
    default: object = None

    def as_json(self) -> dict:
        return {"name": self.name, "kind": self.kind, "label": self.label,
                "options": list(self.options), "low": self.low, "high": self.high,
                "step": self.step, "default": self.default}


# (leaf, kind, label, low, high, step) of the numeric and boolean controls, when the scene has
# the leaf
_NUMBERS = (
    ("human.beta", "float", "human β (rationality; 0 = erratic)", 0.0, 30.0, 0.1),
    ("human.blind", "bool", "blind human", 0, 0, 0),
    ("robot.pos_noise_m", "float", "robot sensor noise [m]", 0.0, 2.0, 0.05),
    ("robot.epsilon", "float", "ε (robot's belief threshold)", 0.0, 0.5, 0.01),
)
TEACHING_SCENES = ("occluded_crosswalk", "t_intersection", "signalized_intersection")


def _variant_options(scenario: str, leaf: str) -> tuple[str, ...]:
    values = [v.get(leaf) for v in SCENARIOS[scenario].variants]
    return tuple(dict.fromkeys(v for v in values if isinstance(v, str)))


def scene_controls(scenario: str) -> list[Control]:
    """The controls of a scene, in page order (SettingsError: an unknown scene)."""
    if scenario not in SCENARIOS:
        raise SettingsError(f"unknown scene {scenario!r}{_did_you_mean(scenario, SCENARIOS)}")
    leaves = settings_leaves(SCENARIOS[scenario].params_cls)
    scenes = tuple(s for s in (*TEACHING_SCENES, *SCENARIOS) if s in SCENARIOS)
    controls = [Control("scenario", "choice", "scene", tuple(dict.fromkeys(scenes)),
                        default=scenario)]
    for leaf in VARIANT_LEAVES:
        options = _variant_options(scenario, leaf) if leaf in leaves else ()
        if options:
            controls.append(Control(leaf, "choice", leaf.replace("_", " "), options,
                                    default=leaves[leaf].default))
    controls.append(Control("robot.planner", "choice", "robot planner", ROBOT_PLANNERS,
                            default=leaves["robot.planner"].default))
    for name, kind, label, low, high, step in _NUMBERS:
        if name in leaves:
            controls.append(Control(name, kind, label, (), low, high, step,
                                    leaves[name].default))
    if "robot.theta_hat" in leaves:
        controls.append(Control("robot.theta_hat", "choice", "robot's θ̂ (model of the humans)",
                                tuple(THETA_HAT_PRESETS), default="true"))
    controls.append(Control("seed", "int", "seed", (), 0, MAX_SEED, 1, 0))
    return controls


def _did_you_mean(word, choices) -> str:
    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def _short(value, limit: int = 40) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _checked_value(control: Control, value):
    """The value a control takes from a page's request (SettingsError otherwise)."""
    where = f"{control.label} ({control.name})"
    if control.kind == "choice":
        if value not in control.options:
            raise SettingsError(f"{where}: {_short(value)} is not one of "
                                f"{', '.join(map(str, control.options))}"
                                f"{_did_you_mean(value, control.options)}")
        return value
    if control.kind == "bool":
        if not isinstance(value, bool):
            raise SettingsError(f"{where}: expected true or false, got {_short(value)}")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SettingsError(f"{where}: expected a number, got {_short(value)}")
    if not math.isfinite(value) or not control.low <= value <= control.high:
        raise SettingsError(f"{where}: {_short(value)} is outside "
                            f"[{control.low:g}, {control.high:g}]")
    if control.kind == "int":
        if int(value) != value:
            raise SettingsError(f"{where}: expected an integer, got {_short(value)}")
        return int(value)
    return float(value)


def validate_request(values: dict) -> tuple[str, dict, int]:
    """(scene, {leaf: value} for the env, seed) from a page's {control: value}.

    Controls left out keep their defaults. A `robot.theta_hat` preset becomes its weights.

    Raises:
        SettingsError: not a mapping, an unknown control (with a suggestion), a value of the
            wrong type or out of range, or one the scenario's own validation refuses.
    """
    if not isinstance(values, dict):
        raise SettingsError(f"settings: expected an object of control: value, got "
                            f"{type(values).__name__}")
    scenario = values.get("scenario", "occluded_crosswalk")
    if not isinstance(scenario, str):
        raise SettingsError(f"scene: expected a name, got {_short(scenario)}")
    controls = {c.name: c for c in scene_controls(scenario)}
    settings, seed = {}, 0
    for name, value in values.items():
        if name not in controls:
            raise SettingsError(f"unknown control {_short(name)} for scene {scenario!r}"
                                f"{_did_you_mean(name, controls)} (controls: "
                                f"{', '.join(controls)})")
        checked = _checked_value(controls[name], value)
        if name == "seed":
            seed = checked_seed(checked)
        elif name == "robot.theta_hat":
            settings[name] = THETA_HAT_PRESETS[checked]
        elif name != "scenario":
            settings[name] = checked
    try:
        make_params(SCENARIOS[scenario].params_cls, settings)
    except (TypeError, ValueError) as err:
        raise SettingsError(str(err).splitlines()[0]) from None
    return scenario, settings, seed
