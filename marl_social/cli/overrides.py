"""`--set KEY=VALUE` scenario overrides: parsed by the field's type, validated by the scenario.

Each value is converted by the type of the scenario parameter it names (the defaults of the
scenario's params dataclass, `marl_social.scenarios.base.make_params`): a bool from
true/false/yes/no/on/off/1/0, an int or float from its text, a tuple from a comma-separated or
JSON list of numbers (or, for `robot_theta_hat`, the path of a `marl-social irl fit` result), a
string as given. The scenario's own parameter validation then checks the whole set, so a bad
value fails with that validation's one-line message.
"""

from __future__ import annotations

import difflib
import json
import re
import warnings

from marl_social.data import strict_json
from marl_social.scenarios import SCENARIOS
from marl_social.scenarios.settings_tree import Leaf, settings_leaves

TRUE_WORDS = ("true", "yes", "on", "1")
FALSE_WORDS = ("false", "no", "off", "0")


def did_you_mean(word: str, choices) -> str:
    """"; did you mean 'x'?" for the closest of `choices` to `word`, else "" (difflib).

    Args:
        word: the unknown name the user typed.
        choices: the valid names.
    """
    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def unknown_name(kind: str, word: str, choices) -> ValueError:
    """A ValueError for an unknown `kind` name with a suggestion and the valid names.

    Args:
        kind: what the name is ("planner", "scenario", "study", ...).
        word: the unknown name.
        choices: the valid names.
    """
    return ValueError(f"unknown {kind} {word!r}{did_you_mean(word, choices)} "
                      f"(choose from {', '.join(map(str, choices))})")


def scenario_class(name: str):
    """The registered scenario class called `name`, else a ValueError with a suggestion."""
    if name not in SCENARIOS:
        raise unknown_name("scenario", name, sorted(SCENARIOS))
    return SCENARIOS[name]


def variant_names(scenario: str, key: str) -> list[str]:
    """The values a scenario's representative variants give the string parameter `key`."""
    values = [v.get(key) for v in scenario_class(scenario).variants]
    return list(dict.fromkeys(v for v in values if isinstance(v, str)))


_SETTING_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.]*")


def split_assignment(text: str) -> tuple[str, str]:
    """("key", "value") from "key=value" (the value may hold "="), else a ValueError."""
    key, sep, value = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ValueError(f"--set {text!r}: expected KEY=VALUE, e.g. --set human.blind=true")
    if not _SETTING_NAME.fullmatch(key):
        raise ValueError(f"--set {text!r}: a setting's name is letters, digits, _ and dots "
                         "(`marl-social params SCENARIO` lists them)")
    return key, value.strip()


def _shown(text: str) -> str:
    """A value as an error line shows it: as given, or quoted with escapes if not printable."""
    return text if text.isprintable() else repr(text)


def _convert(params_cls, key: str, text: str):
    """`text` as the type of `params_cls`'s field `key` (ValueError naming the field)."""
    default = getattr(params_cls, key)
    where = f"--set {key}={_shown(text)}"
    if isinstance(default, bool):
        word = text.lower()
        if word in TRUE_WORDS:
            return True
        if word in FALSE_WORDS:
            return False
        raise ValueError(f"{where}: {params_cls.__name__}.{key} is a bool; use true or false")
    if isinstance(default, tuple):
        if not text or text in ("()", "[]"):
            return ()
        if text.endswith(".json") or "/" in text:  # a file (e.g. robot_theta_hat=theta.json)
            return text
        try:
            values = json.loads(text) if text.startswith("[") else [
                float(v) for v in text.split(",")]
        except ValueError:
            raise ValueError(f"{where}: {params_cls.__name__}.{key} is a list of numbers; "
                             "give e.g. 0,1,0.1 or [0, 1, 0.1]") from None
        if isinstance(values, list):
            return tuple(values)
        raise ValueError(f"{where}: {params_cls.__name__}.{key} is a list of numbers")
    return text  # int, float (make_params parses numeric strings) and str fields


def parse_overrides(scenario: str, assignments) -> dict:
    """Typed, validated scenario overrides from `--set` texts.

    Args:
        scenario: the registered scenario the overrides are for.
        assignments: the "KEY=VALUE" texts, in order (a later one wins).

    Returns:
        {parameter: value} as the scenario's validated parameters hold it (each of its field's
        type; a fit result's path as the weights the scenario loaded from it).

    Raises:
        ValueError: a malformed assignment, an unknown parameter (with a suggestion) or a value
            the scenario's parameter validation rejects (its one-line message).
    """
    cls = scenario_class(scenario)
    params_cls = cls.params_cls
    leaves = settings_leaves(params_cls)
    fields = {leaf.field: leaf.name for leaf in leaves.values() if leaf.field}
    overrides = {}
    for text in assignments or ():
        key, value = split_assignment(text)
        if key in fields and fields[key] != key:
            warnings.warn(f"--set {key}: the flat name is deprecated and goes in the next "
                          f"release; use --set {fields[key]}={value}", FutureWarning,
                          stacklevel=2)
            key = fields[key]
        if key not in leaves:
            raise ValueError(f"--set {key}: unknown setting of scenario {scenario!r}"
                             f"{did_you_mean(key, list(leaves) + list(fields))} (see "
                             f"`marl-social params {scenario}`)")
        leaf = leaves[key]
        if leaf.field is None:  # a robot part's leaf (robot.mpc.w_speed, ...)
            overrides[key] = _convert_leaf(leaf, value)
        else:
            overrides[leaf.field] = _convert(params_cls, leaf.field, value)
    if "robot_planner" in overrides:
        from marl_social.agents.registry import ROBOT_PLANNERS

        if overrides["robot_planner"] not in ROBOT_PLANNERS:
            raise unknown_name("planner", overrides["robot_planner"], list(ROBOT_PLANNERS))
    for key, value in overrides.items():  # named variants (e.g. pedestrian=crossing)
        named = variant_names(scenario, key)
        if named and isinstance(value, str) and value not in named:
            raise unknown_name(f"{key} variant", value, named)
    try:
        params = cls(**overrides).params  # the scenario's own validation of every value
    except TypeError as err:  # make_params reports a wrong type as TypeError
        raise ValueError(str(err)) from None
    return {key: (getattr(params, key) if "." not in key else value)
            for key, value in overrides.items()}


def _convert_leaf(leaf: Leaf, text: str):
    """`text` as a robot part leaf's value (its type's parsing; the robot checks the range)."""
    where = f"--set {leaf.name}={_shown(text)}"
    if leaf.type == "bool":
        if text.lower() in TRUE_WORDS + FALSE_WORDS:
            return text.lower() in TRUE_WORDS
        raise ValueError(f"{where}: a bool; use true or false")
    if leaf.type == "list":
        try:
            values = json.loads(text) if text.startswith("[") else [
                float(v) for v in text.split(",")]
        except ValueError:
            raise ValueError(f"{where}: a list of numbers; give e.g. 0,1,0.1") from None
        return tuple(values)
    try:
        return float(text) if leaf.type == "float" else int(text)
    except ValueError:
        raise ValueError(f"{where}: expected {'a number' if leaf.type == 'float' else 'an integer'}"
                         ) from None


def describe_params(scenario: str, as_json: bool = False) -> str:
    """Every setting of `scenario`: name, type, unit, default and meaning, one a line.

    Args:
        scenario: a registered scenario.
        as_json: a JSON object {dotted name: {type, unit, default, doc}} instead (for tools).
    """
    params_cls = scenario_class(scenario).params_cls
    leaves = settings_leaves(params_cls)
    if as_json:
        return strict_json.dumps({name: leaf.as_json() for name, leaf in leaves.items()},
                                 indent=1)
    lines = [f"scenario {scenario!r} ({params_cls.__name__}); set with --set NAME=VALUE:"]
    for name, leaf in leaves.items():
        unit = f" [{leaf.unit}]" if leaf.unit and "[" not in leaf.doc else ""
        lines.append(f"  {name:<40} {leaf.type:<5} {leaf.default!r:<14} {leaf.doc}{unit}")
    return "\n".join(lines)
