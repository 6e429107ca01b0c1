"""`--set KEY=VALUE` scenario overrides: parsed by the field's type, validated by the scenario.

Each value is converted by the type of the scenario parameter it names (the defaults of the
scenario's params dataclass, `marl_social.scenarios.base.make_params`): a bool from
true/false/yes/no/on/off/1/0, an int or float from its text, a tuple from a comma-separated or
JSON list of numbers (or, for `robot_theta_hat`, the path of a `marl-social irl fit` result), a
string as given. The scenario's own parameter validation then checks the whole set, so a bad
value fails with that validation's one-line message.
"""

from __future__ import annotations

import dataclasses
import difflib
import json

from marl_social.scenarios import SCENARIOS

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


def split_assignment(text: str) -> tuple[str, str]:
    """("key", "value") from "key=value" (the value may hold "="), else a ValueError."""
    key, sep, value = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ValueError(f"--set {text!r}: expected KEY=VALUE, e.g. --set human_blind=true")
    return key, value.strip()


def _convert(params_cls, key: str, text: str):
    """`text` as the type of `params_cls`'s field `key` (ValueError naming the field)."""
    default = getattr(params_cls, key)
    where = f"--set {key}={text}"
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
    names = [f.name for f in dataclasses.fields(params_cls)]
    overrides = {}
    for text in assignments or ():
        key, value = split_assignment(text)
        if key not in names:
            raise ValueError(f"--set {key}: unknown parameter of scenario {scenario!r}"
                             f"{did_you_mean(key, names)} (see `marl-social params "
                             f"{scenario}`)")
        overrides[key] = _convert(params_cls, key, value)
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
    return {key: getattr(params, key) for key in overrides}


def describe_params(scenario: str) -> str:
    """Every parameter of `scenario` with its type and default, one a line."""
    params_cls = scenario_class(scenario).params_cls
    lines = [f"scenario {scenario!r} ({params_cls.__name__}); set with --set KEY=VALUE:"]
    for f in dataclasses.fields(params_cls):
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        lines.append(f"  {f.name:<28} {type(default).__name__:<6} default {default!r}")
    return "\n".join(lines)
