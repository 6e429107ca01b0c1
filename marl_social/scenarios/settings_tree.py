"""The settings tree of a scenario: every leaf with its type, unit, default and meaning.

Leaves are dotted names: `env.*` (observation slots and rays, collision penalty, termination),
`human.*`, `pedestrian.*` and `robot.*` (planner, epsilon, its model of the humans) from the
scenario's parameters (scenarios/base.dotted_name), the robot's parts `robot.mpc.*`,
`robot.belief.*`, `robot.curb.*`, `robot.stop_line.*`, `robot.right_of_way.*`, `robot.hold.*`
(agents/robot/settings.STAGE_PARTS), and the scene's layout knobs by their own name. Each is
set with `--set NAME=VALUE` (or `parallel_env(**{NAME: VALUE})`) and swept by a study; the
flat names (robot_epsilon) still work.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass

from marl_social.agents.robot.settings import STAGE_PARTS, stage_leaf_fields
from marl_social.scenarios.base import ScenarioParams, dotted_name

# unit of a leaf from its name's suffix (SI, as the names carry them)
_UNITS = (("_mps3", "m/s^3"), ("_mps2", "m/s^2"), ("_mps", "m/s"), ("_rad", "rad"),
          ("_deg", "deg"), ("_per_s", "1/s"), ("_m", "m"), ("_s", "s"))


@dataclass(frozen=True)
class Leaf:
    """One setting.

    Attributes:
        name: its dotted name.
        type: "bool", "int", "float", "str" or "list" (of numbers).
        default: its default (JSON-able).
        unit: its SI unit ("" where none).
        doc: one line on what it means.
        field: the scenario parameter it sets (None for a robot part's leaf).
    """

    name: str
    type: str
    default: object
    unit: str
    doc: str
    field: str | None = None

    def as_json(self) -> dict:
        """{type, unit, default, doc} (the JSON listing's value)."""
        return {"type": self.type, "unit": self.unit, "default": self.default, "doc": self.doc}


def _unit(name: str) -> str:
    return next((unit for suffix, unit in _UNITS if name.endswith(suffix)), "")


def _type_name(default) -> str:
    if isinstance(default, bool):
        return "bool"
    if isinstance(default, int):
        return "int"
    if isinstance(default, (float, type(None))):
        return "float"
    if isinstance(default, tuple):
        return "list"
    return type(default).__name__


def _jsonable(default):
    if isinstance(default, float) and not math.isfinite(default):
        return None if math.isnan(default) else str(default)  # strict JSON has no inf
    return list(default) if isinstance(default, tuple) else default


def attribute_docs(cls: type) -> dict[str, str]:
    """{field: the first sentence of its entry} from a class docstring's Attributes section.

    An entry may name several fields ("robot_speed_mps, human_speed_mps: initial speeds");
    the classes' bases are read first (a base's entry wins: a subclass's may only refer
    to it).
    """
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        text = klass.__doc__ or ""
        if "Attributes:" not in text:
            continue
        section = text.split("Attributes:", 1)[1]
        entries = re.split(r"\n {8}(?=\w[\w, ]*:\s)", "\n" + section)
        for entry in entries:
            names, sep, body = entry.partition(":")
            if not sep:
                continue
            first = _first_sentence(" ".join(body.split()))
            for name in names.split(","):
                name = name.strip()
                if name.isidentifier():
                    # an entry of a unit alone ("[m]") is named by the field
                    docs.setdefault(name, first if first and not first.startswith("[") else
                                  f"{_words(name)} {first}".strip())
    return docs


def _first_sentence(text: str) -> str:
    """`text` up to its first ". " or "; " outside parentheses and brackets."""
    depth = 0
    for i, char in enumerate(text):
        depth += char in "([" and 1 or (-1 if char in ")]" else 0)
        if depth == 0 and char in ".;" and text[i + 1:i + 2] in (" ", ""):
            return text[:i]
    return text


def _words(name: str) -> str:
    """A field's name as words, without its agent prefix and unit suffix."""
    for suffix, _ in _UNITS:
        if name.endswith(suffix):
            name = name[:-len(suffix)]
            break
    return name.split("_", 1)[-1].replace("_", " ") if "_" in name else name


def scenario_leaves(params_cls: type[ScenarioParams]) -> list[Leaf]:
    """The leaves a scenario's parameters give (layout, env, agents' models)."""
    docs = attribute_docs(params_cls)
    out = []
    for f in dataclasses.fields(params_cls):
        if f.name == "robot_stage_settings":
            continue
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        out.append(Leaf(dotted_name(f.name), _type_name(default), _jsonable(default),
                        _unit(f.name), docs.get(f.name, ""), f.name))
    return out


def robot_part_leaves() -> list[Leaf]:
    """The leaves of the robot's parts (robot.mpc.*, robot.belief.*, ...)."""
    out = []
    for part, (_, cls) in STAGE_PARTS.items():
        docs = attribute_docs(cls)
        for f in stage_leaf_fields(part):
            out.append(Leaf(f"robot.{part}.{f.name}", _type_name(f.default),
                            _jsonable(f.default), _unit(f.name), docs.get(f.name, "")))
    return out


def settings_leaves(params_cls: type[ScenarioParams]) -> dict[str, Leaf]:
    """{dotted name: Leaf} of every setting of a scenario, sorted by name."""
    leaves = scenario_leaves(params_cls) + robot_part_leaves()
    return {leaf.name: leaf for leaf in sorted(leaves, key=lambda leaf: leaf.name)}
