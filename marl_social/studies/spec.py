"""Study specs: the TOML model of a sensitivity study and its parsing from a TOML table.

Loading a spec file, its validation against the scenario and its expansion into runs are in
`marl_social/studies/runs.py`; studies run with `marl_social/studies/runner.py`.

A study is a TOML spec; the built-in ones live in `marl_social/studies/specs/`
(`marl-social study --list`)::

    name = "my-study"                     # output folder name (default: the file's stem)
    description = "what it asks"          # optional
    scenario = "occluded_crosswalk"       # default
    seeds = 20                            # range(20), or a list such as [0, 5, 7]
    planners = ["social", "aggressive"]   # default: social, aggressive, conservative, oracle
    pedestrians = ["crossing", "none"]    # default: crossing, waiting, none
    max_cycles = 150                      # episode length limit [steps of 0.1 s]
    randomize = true                      # start from run.scenario_randomized_overrides
    sample_seed = 0                       # seeds the [random] draws
    metrics = ["robot_collision", "time_to_pass_s"]   # default: DEFAULT_METRICS

    [fixed]                               # one value per parameter
    human_blind = true
    [grid]                                # lists of values, combined by cartesian product
    human_beta = [0.5, 1, 3, 10, inf]
    [random]                              # n values drawn once from sample_seed
    human_lead_m = {low = 17, high = 23, n = 4}                 # uniform (log = true: log-uniform)
    pedestrian_speed_mps = {choices = [1.1, 1.3, 1.5], n = 2}   # n distinct choices

Every [random] parameter is an axis of n distinct values (drawn deterministically from
sample_seed and the parameter's name; integer parameters draw distinct integers in [low, high]);
the grid and random axes are combined by cartesian product. A run's overrides are, in order of
precedence (last wins): `run.scenario_randomized_overrides(seed, scenario)` if randomize,
[fixed], the run's grid/random point, its planner (`robot_planner`) and its pedestrian variant. A spec is fully
validated before anything runs: unknown keys, parameters, planners or metrics and values the
scenario rejects are a `ValueError` naming the file and the key.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import NamedTuple

from marl_social.envs.parallel import MAX_CYCLES
from marl_social.sim.seeds import MAX_SEED

DEFAULT_PLANNERS = ("social", "aggressive", "conservative", "oracle")
DEFAULT_PEDESTRIANS = ("crossing", "waiting", "none")
DEFAULT_METRICS = (
    "robot_collision", "yielded", "hard_brake", "max_decel_mps2", "time_to_pass_s",
    "mean_speed_mps", "min_gap_pedestrian_m",
    # belief metrics (nan for the oracle, which has no belief)
    "robot_first_sees_pedestrian_s", "p_pedestrian_before_seen", "belief_confident_before_seen",
    "brake_to_confident_s", "p_pedestrian_at_crosswalk", "brier",
)
DEFAULT_MAX_CYCLES = 150
DEFAULT_SEEDS = 10
SPEC_PACKAGE_DIR = "specs"  # inside marl_social.studies
MAX_SEEDS = 100_000  # most seeds in a study
MAX_AXIS_VALUES = 10_000  # most values a [random] parameter draws (its n)
MAX_INT_RANGE = 2**62  # widest [low, high] range of an integer [random] parameter
MAX_RUNS = 1_000_000  # most runs (episodes) in a study
# spec keys that are not scenario parameters, and scenario fields a spec may not sweep directly
_SPEC_KEYS = ("name", "description", "scenario", "seeds", "planners", "pedestrians",
              "max_cycles", "randomize", "sample_seed", "metrics", "fixed", "grid", "random")
_RESERVED = {"robot_planner": "planners", "pedestrian": "pedestrians"}
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]*$")


class Run(NamedTuple):
    """One episode of a study: its canonical key, its overrides and its seed.

    The overrides are passed to `run_episode` (randomized, fixed and swept parameters,
    robot_planner, pedestrian).
    """

    key: str
    overrides: dict
    seed: int


@dataclass(frozen=True)
class StudySpec:
    """A parsed study spec (see the module docstring for the TOML format).

    Attributes:
        name: study name (the default output folder's name).
        source: where the spec came from (a file path), used in error messages.
        scenario: registered scenario name.
        seeds: episode seeds.
        planners: robot planners (`robot_planner` values).
        pedestrians: pedestrian variants; None = DEFAULT_PEDESTRIANS if the scenario has a
            `pedestrian` parameter, else no variant.
        fixed: parameter -> value applied to every run.
        grid: parameter -> tuple of values (cartesian product).
        random: parameter -> draw rule ({low, high, n[, log]} or {choices, n}).
        max_cycles: episode length limit [steps].
        randomize: start every run from `run.scenario_randomized_overrides(seed, scenario)`
            (the occluded crosswalk's "paper" preset, each intersection's own; none for
            long_road).
        sample_seed: seeds the [random] draws.
        metrics: `run_episode` metric names stored per run.
    """

    name: str
    source: str = "<spec>"
    description: str = ""
    scenario: str = "occluded_crosswalk"
    seeds: tuple[int, ...] = tuple(range(DEFAULT_SEEDS))
    planners: tuple[str, ...] = DEFAULT_PLANNERS
    pedestrians: tuple[str, ...] | None = None
    fixed: dict = field(default_factory=dict)
    grid: dict = field(default_factory=dict)
    random: dict = field(default_factory=dict)
    max_cycles: int = DEFAULT_MAX_CYCLES
    randomize: bool = True
    sample_seed: int = 0
    metrics: tuple[str, ...] = DEFAULT_METRICS

    @property
    def param_names(self) -> list[str]:
        """The spec's scenario parameters ([fixed], [grid] and [random]), sorted."""
        return sorted({*self.fixed, *self.grid, *self.random})

    def section_of(self, name: str) -> str:
        """Where a parameter is set in the spec, e.g. "[grid] human_beta"."""
        for section in ("fixed", "grid", "random"):
            if name in getattr(self, section):
                return f"[{section}] {name}"
        return _RESERVED.get(name, name)


# ----------------------------------------------------------------------------- spec parsing


def _spec_error(source: str, key: str, message: str) -> ValueError:
    return ValueError(f"{source}: {key}: {message}")


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _str_list(data: dict, key: str, source: str) -> tuple[str, ...] | None:
    if key not in data:
        return None
    value = data[key]
    if (not isinstance(value, list) or not value
            or not all(isinstance(v, str) and v for v in value)):
        raise _spec_error(source, key, f"expected a non-empty list of names, got {value!r}")
    duplicates = sorted({v for v in value if value.count(v) > 1})
    if duplicates:
        raise _spec_error(source, key, f"duplicate entries {duplicates}")
    return tuple(value)


def _parse_seeds(value, source: str) -> tuple[int, ...]:
    if _is_int(value):
        if not 1 <= value <= MAX_SEEDS:
            raise _spec_error(source, "seeds", f"the number of seeds must be >= 1 and <= "
                              f"{MAX_SEEDS}, got {value}")
        return tuple(range(value))
    if isinstance(value, list) and len(value) > MAX_SEEDS:
        raise _spec_error(source, "seeds", f"at most {MAX_SEEDS} seeds, got {len(value)}")
    if (isinstance(value, list) and value
            and all(_is_int(s) and 0 <= s <= MAX_SEED for s in value)):
        if len(set(value)) != len(value):
            raise _spec_error(source, "seeds", f"duplicate seeds in {value}")
        return tuple(value)
    raise _spec_error(source, "seeds", "expected a number of seeds N (range(N)) or a non-empty "
                      f"list of distinct integers in [0, {MAX_SEED}], got {str(value)[:80]}")


def _parse_table(data: dict, key: str, source: str) -> dict:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise _spec_error(source, key, f"expected a table [{key}], got {value!r}")
    return dict(value)


def _check_values(values, source: str, where: str) -> None:
    """Every value a bool, number, string or list of them (not a TOML date or time)."""
    for value in values:
        items = value if isinstance(value, list) else [value]
        bad = [v for v in items if not isinstance(v, (bool, int, float, str))]
        if bad:
            raise _spec_error(source, where, f"values must be numbers, true/false, strings or "
                              f"lists of them, got {bad[0]!r} ({type(bad[0]).__name__})")


def _parse_grid(data: dict, source: str) -> dict:
    grid = _parse_table(data, "grid", source)
    for name, values in grid.items():
        if not isinstance(values, list) or not values:
            raise _spec_error(source, f"[grid] {name}", f"expected a non-empty list of values, "
                              f"got {values!r}")
        if len(values) > MAX_AXIS_VALUES:
            raise _spec_error(source, f"[grid] {name}", f"at most {MAX_AXIS_VALUES} values, "
                              f"got {len(values)}")
        _check_values(values, source, f"[grid] {name}")
        grid[name] = tuple(values)
    return grid


def _parse_random(data: dict, source: str) -> dict:
    rules = _parse_table(data, "random", source)
    for name, rule in rules.items():
        where = f"[random] {name}"
        if not isinstance(rule, dict):
            raise _spec_error(source, where, "expected {low, high, n} or {choices, n}, "
                              f"got {rule!r}")
        n = rule.get("n")
        if not _is_int(n) or not 1 <= n <= MAX_AXIS_VALUES:
            raise _spec_error(source, where, f"n must be an integer in [1, {MAX_AXIS_VALUES}], "
                              f"got {n!r}")
        if "choices" in rule:
            unknown = sorted(set(rule) - {"choices", "n"})
            choices = rule["choices"]
            if unknown:
                raise _spec_error(source, where, f"unknown key(s) {unknown} with choices")
            if not isinstance(choices, list) or len(choices) < n:
                raise _spec_error(source, where, f"choices must be a list of at least n={n} "
                                  f"values, got {choices!r}")
            _check_values(choices, source, where)
            continue
        unknown = sorted(set(rule) - {"low", "high", "n", "log"})
        if unknown:
            raise _spec_error(source, where, f"unknown key(s) {unknown}; expected low, high, n "
                              "and optionally log (or choices and n)")
        low, high = rule.get("low"), rule.get("high")
        if not (_is_number(low) and _is_number(high) and math.isfinite(low)
                and math.isfinite(high) and low < high):
            raise _spec_error(source, where, f"need finite numbers low < high, got low={low!r}, "
                              f"high={high!r}")
        if not isinstance(rule.get("log", False), bool):
            raise _spec_error(source, where, f"log must be true or false, got {rule['log']!r}")
        if rule.get("log", False) and low <= 0:
            raise _spec_error(source, where, f"log = true needs low > 0, got {low}")
    return rules


def _get(data: dict, key: str, kind, default, source: str, check=None, expected: str = ""):
    value = data.get(key, default)
    ok = isinstance(value, kind) and not (kind is int and isinstance(value, bool))
    if not ok or (check is not None and not check(value)):
        raise _spec_error(source, key, f"expected {expected}, got {value!r}")
    return value


def parse_spec(data: dict, source: str = "<spec>", default_name: str = "") -> StudySpec:
    """Check a spec's structure (keys and types) and build a StudySpec.

    `validate` and `expand` check it against the scenario. Raises ValueError naming `source`
    and the key.
    """
    if not data:
        raise _spec_error(source, "spec", "empty: a study names at least its scenario or a "
                          "[grid] (e.g. scenario = \"occluded_crosswalk\"; `marl-social study "
                          "--list` shows the built-in studies)")
    unknown = sorted(set(data) - set(_SPEC_KEYS))
    if unknown:
        raise _spec_error(source, ", ".join(unknown), f"unknown key(s); valid: {list(_SPEC_KEYS)} "
                          "(scenario parameters go in [fixed], [grid] or [random])")
    name = _get(data, "name", str, default_name, source, lambda v: bool(_NAME_RE.match(v)),
                "a name of letters, digits and _ . + - (it names the output folder)")
    fixed, grid, rand = (_parse_table(data, "fixed", source), _parse_grid(data, source),
                         _parse_random(data, source))
    for name, value in fixed.items():
        _check_values([value], source, f"[fixed] {name}")
    section_of: dict[str, str] = {}
    for section, table in (("fixed", fixed), ("grid", grid), ("random", rand)):
        for param in table:
            if param in section_of:
                raise _spec_error(source, f"[{section}] {param}", f"also set in "
                                  f"[{section_of[param]}]; a parameter belongs to one of "
                                  "[fixed], [grid], [random]")
            if param in _RESERVED:
                raise _spec_error(source, f"[{section}] {param}", "set it with the top-level "
                                  f"`{_RESERVED[param]}` list")
            section_of[param] = section
    return StudySpec(
        name=name, source=source, fixed=fixed, grid=grid, random=rand,
        description=_get(data, "description", str, "", source, expected="a string"),
        scenario=_get(data, "scenario", str, "occluded_crosswalk", source,
                      expected="a scenario name"),
        seeds=_parse_seeds(data.get("seeds", DEFAULT_SEEDS), source),
        planners=_str_list(data, "planners", source) or DEFAULT_PLANNERS,
        pedestrians=_str_list(data, "pedestrians", source),
        max_cycles=_get(data, "max_cycles", int, DEFAULT_MAX_CYCLES, source,
                        lambda v: 1 <= v <= MAX_CYCLES, f"an integer in [1, {MAX_CYCLES}] [steps]"),
        randomize=_get(data, "randomize", bool, True, source, expected="true or false"),
        sample_seed=_get(data, "sample_seed", int, 0, source, lambda v: v >= 0,
                         "an integer >= 0"),
        metrics=_str_list(data, "metrics", source) or DEFAULT_METRICS,
    )
