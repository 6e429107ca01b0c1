"""Sensitivity studies: sweeps of scenario parameters x robot planners x pedestrian variants x
seeds, one simulated episode (`run.run_episode`) per run, on a local process pool or on Ray.

A study is a TOML spec; the built-in ones live in `marl_social/study_specs/`
(`marl-social study --list`)::

    name = "my-study"                     # output folder name (default: the file's stem)
    description = "what it asks"          # optional
    scenario = "occluded_crosswalk"       # default
    seeds = 20                            # range(20), or a list such as [0, 5, 7]
    planners = ["social", "aggressive"]   # default: social, aggressive, conservative, oracle
    pedestrians = ["crossing", "none"]    # default: crossing, waiting, none
    max_cycles = 150                      # episode length limit [steps of 0.1 s]
    randomize = true                      # start every run from run.randomized_overrides(seed)
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
precedence (last wins): `run.randomized_overrides(seed)` if randomize, [fixed], the run's
grid/random point, its planner (`robot_planner`) and its pedestrian variant. A spec is fully
validated before anything runs: unknown keys, parameters, planners or metrics and values the
scenario rejects are a `ValueError` naming the file and the key.

Results: `<out>/results.csv` (default out: marl_social_out/studies/<name>/), one row per run,
appended as soon as the run finishes (flushed and fsynced), columns: key, seed, planner,
pedestrian, each [fixed]/[grid]/[random] parameter, each metric, error, elapsed_s. The key is a
canonical string of the scenario, the run's parameters (planner and pedestrian included) and
the seed. Every column except elapsed_s (the run's wall time [s]) is deterministic: the same
spec and seeds give the same rows from any backend and number of workers. Floats are written
with repr precision, bools as true/false; a failed run has empty metric cells. When a study
completes, the table is rewritten in the spec's order (planner, pedestrian, point, seed); runs
execute seed-major, so an interrupted study has every cell covered by its first seeds.
`<out>/study.json` records the resolved spec.

Resume: with `resume=True` (`--resume`) every finished row is kept and only the missing keys
run; a truncated last line (the process was killed while writing it) is dropped. A run that
raised is recorded with its error ("TypeName: message") and counts as finished: resume does not
retry it unless `retry_failed=True` (`--retry-failed`), which removes its row and runs it again.
No key is ever written twice, and a lock on the folder (.study.lock) keeps a second process
from running a study into it at the same time. Without resume an existing results.csv is an error (pass --resume
or --overwrite); resuming into a folder whose study differs in scenario, max_cycles, randomize,
parameters or metrics is an error too.

Backends: "local" runs in process with 1 worker, else on a spawn-context process pool;
"ray" sends one remote task per run to the cluster at `address`, to the one this process is
already connected to, to a running local cluster (address "auto"), or else to a new local Ray
with `workers` CPUs (shut down at the end). Ray is optional: `pip install marl-social[ray]`;
every cluster node needs marl-social installed.

Analysis (`marl_social/study_analysis.py`) runs at the end of a study: plots and summary.md /
summary.csv next to results.csv.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import io
import itertools
import json
import math
import os
import re
import sys
import time
import tomllib
import zlib
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

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
DEFAULT_OUT_ROOT = Path("marl_social_out") / "studies"
BACKENDS = ("local", "ray")
RESULTS_FILE = "results.csv"
META_FILE = "study.json"
LOCK_FILE = ".study.lock"
SPEC_PACKAGE_DIR = "study_specs"
HEAD_COLUMNS = ("key", "seed", "planner", "pedestrian")
TAIL_COLUMNS = ("error", "elapsed_s")
# spec keys that are not scenario parameters, and scenario fields a spec may not sweep directly
_SPEC_KEYS = ("name", "description", "scenario", "seeds", "planners", "pedestrians",
              "max_cycles", "randomize", "sample_seed", "metrics", "fixed", "grid", "random")
_RESERVED = {"robot_planner": "planners", "pedestrian": "pedestrians"}
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]*$")
_MAX_ERROR_CHARS = 500


class Run(NamedTuple):
    """One episode of a study: its canonical key, the overrides passed to `run_episode`
    (randomized, fixed and swept parameters, robot_planner, pedestrian) and its seed."""

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
        randomize: start every run from `run.randomized_overrides(seed)`.
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


@dataclass
class StudyOutcome:
    """What `run_study` did: the output folder and table, and counts of runs."""

    out_dir: Path
    results_path: Path
    n_runs: int  # runs in the spec
    n_skipped: int  # already in the table (resume)
    n_executed: int
    n_errors: int  # errors among the executed runs
    analysis: Any = None  # study_analysis.AnalysisOutputs, or None


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
        if value < 1:
            raise _spec_error(source, "seeds", f"the number of seeds must be >= 1, got {value}")
        return tuple(range(value))
    if (isinstance(value, list) and value and all(_is_int(s) and s >= 0 for s in value)):
        if len(set(value)) != len(value):
            raise _spec_error(source, "seeds", f"duplicate seeds in {value}")
        return tuple(value)
    raise _spec_error(source, "seeds", "expected a number of seeds N (range(N)) or a non-empty "
                      f"list of distinct integers >= 0, got {value!r}")


def _parse_table(data: dict, key: str, source: str) -> dict:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise _spec_error(source, key, f"expected a table [{key}], got {value!r}")
    return dict(value)


def _parse_grid(data: dict, source: str) -> dict:
    grid = _parse_table(data, "grid", source)
    for name, values in grid.items():
        if not isinstance(values, list) or not values:
            raise _spec_error(source, f"[grid] {name}", f"expected a non-empty list of values, "
                              f"got {values!r}")
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
        if not _is_int(n) or n < 1:
            raise _spec_error(source, where, f"n must be an integer >= 1, got {n!r}")
        if "choices" in rule:
            unknown = sorted(set(rule) - {"choices", "n"})
            choices = rule["choices"]
            if unknown:
                raise _spec_error(source, where, f"unknown key(s) {unknown} with choices")
            if not isinstance(choices, list) or len(choices) < n:
                raise _spec_error(source, where, f"choices must be a list of at least n={n} "
                                  f"values, got {choices!r}")
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
    """Check a spec's structure (keys and types) and build a StudySpec; `validate` and
    `expand` check it against the scenario. Raises ValueError naming `source` and the key."""
    unknown = sorted(set(data) - set(_SPEC_KEYS))
    if unknown:
        raise _spec_error(source, ", ".join(unknown), f"unknown key(s); valid: {list(_SPEC_KEYS)} "
                          "(scenario parameters go in [fixed], [grid] or [random])")
    name = _get(data, "name", str, default_name, source, lambda v: bool(_NAME_RE.match(v)),
                "a name of letters, digits and _ . + - (it names the output folder)")
    fixed, grid, rand = (_parse_table(data, "fixed", source), _parse_grid(data, source),
                         _parse_random(data, source))
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
        max_cycles=_get(data, "max_cycles", int, DEFAULT_MAX_CYCLES, source, lambda v: v >= 1,
                        "an integer >= 1 [steps]"),
        randomize=_get(data, "randomize", bool, True, source, expected="true or false"),
        sample_seed=_get(data, "sample_seed", int, 0, source, lambda v: v >= 0,
                         "an integer >= 0"),
        metrics=_str_list(data, "metrics", source) or DEFAULT_METRICS,
    )


def builtin_specs() -> dict[str, Path]:
    """Built-in study specs shipped with the package: name -> path."""
    folder = resources.files("marl_social").joinpath(SPEC_PACKAGE_DIR)
    return {Path(str(p)).stem: Path(str(p)) for p in sorted(folder.iterdir(), key=str)
            if str(p).endswith(".toml")}


def _resolve_spec_path(name_or_path: str | os.PathLike) -> Path:
    path = Path(name_or_path)
    if path.is_file():
        return path
    specs = builtin_specs()
    if str(name_or_path) in specs:
        return specs[str(name_or_path)]
    if path.suffix == ".toml":
        raise ValueError(f"{path}: no such spec file")
    raise ValueError(f"unknown study {str(name_or_path)!r}: not a file and not a built-in spec "
                     f"(built-in: {sorted(specs)})")


def load_spec(name_or_path: str | os.PathLike, validate: bool = True) -> StudySpec:
    """Read a spec from a TOML file or a built-in name and (by default) validate it fully:
    structure, scenario, parameter names, planners, metrics and every run's parameter values.

    Raises:
        ValueError: naming the file and the key at fault.
    """
    path = _resolve_spec_path(name_or_path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"{path}: malformed TOML: {err}") from None
    spec = parse_spec(data, source=str(path), default_name=path.stem)
    if validate:
        expand(spec)
    return spec


def with_seeds(spec: StudySpec, n_seeds: int) -> StudySpec:
    """The spec with seeds range(n_seeds) (the CLI's --seeds, for quick runs)."""
    if not _is_int(n_seeds) or n_seeds < 1:
        raise ValueError(f"--seeds: expected an integer >= 1, got {n_seeds!r}")
    return dataclasses.replace(spec, seeds=tuple(range(n_seeds)))


# ------------------------------------------------------------------------- validation, runs


@cache
def available_metrics(scenario: str) -> tuple[str, ...]:
    """The metric names `run_episode` returns for a scenario (from a one-step episode)."""
    from marl_social import run

    return tuple(run.run_episode(scenario, seed=0, max_cycles=1).metrics)


def _scenario_fields(spec: StudySpec) -> tuple[type, dict]:
    from marl_social.scenarios import SCENARIOS

    if spec.scenario not in SCENARIOS:
        raise _spec_error(spec.source, "scenario", f"unknown scenario {spec.scenario!r}; "
                          f"available: {sorted(SCENARIOS)}")
    cls = SCENARIOS[spec.scenario].params_cls
    return cls, {f.name: f for f in dataclasses.fields(cls)}


def _check_names(spec: StudySpec, params_cls: type, fields: dict) -> None:
    from marl_social.run import randomized_overrides
    from marl_social.scenarios.base import ROBOT_PLANNER_CHOICES

    for name in spec.param_names:
        if name not in fields:
            raise _spec_error(spec.source, spec.section_of(name),
                              f"unknown parameter for scenario {spec.scenario!r} "
                              f"({params_cls.__name__}); valid: {sorted(fields)}")
    bad = [p for p in spec.planners if p not in ROBOT_PLANNER_CHOICES]
    if bad:
        raise _spec_error(spec.source, "planners", f"unknown planner(s) {bad}; valid: "
                          f"{list(ROBOT_PLANNER_CHOICES)}")
    if spec.pedestrians is not None and "pedestrian" not in fields:
        raise _spec_error(spec.source, "pedestrians", f"scenario {spec.scenario!r} has no "
                          "pedestrian variants; remove the key")
    if spec.randomize:
        foreign = sorted(set(randomized_overrides(0)) - set(fields))
        if foreign:
            raise _spec_error(spec.source, "randomize", "run.randomized_overrides sets "
                              f"{foreign}, which scenario {spec.scenario!r} does not have; "
                              "set randomize = false")
    valid = available_metrics(spec.scenario)
    bad = [m for m in spec.metrics if m not in valid]
    if bad:
        raise _spec_error(spec.source, "metrics", f"unknown metric(s) {bad}; run_episode "
                          f"returns {sorted(valid)}")


def _draw(spec: StudySpec, name: str, field_default) -> tuple:
    """The n values of a [random] parameter: deterministic in (sample_seed, name)."""
    rule = spec.random[name]
    n = rule["n"]
    rng = np.random.default_rng([spec.sample_seed, zlib.crc32(name.encode())])
    if "choices" in rule:
        return tuple(rule["choices"][i] for i in rng.choice(len(rule["choices"]), n,
                                                            replace=False))
    low, high = rule["low"], rule["high"]
    if _is_int(field_default):
        lo_i, hi_i = math.ceil(low), math.floor(high)
        if hi_i - lo_i + 1 < n:
            raise _spec_error(spec.source, f"[random] {name}", f"an integer parameter: "
                              f"[{low}, {high}] holds fewer than n={n} integers")
        return tuple(int(v) for v in rng.choice(np.arange(lo_i, hi_i + 1), n, replace=False))
    if rule.get("log", False):
        return tuple(float(v) for v in np.exp(rng.uniform(np.log(low), np.log(high), n)))
    return tuple(float(v) for v in rng.uniform(low, high, n))


def _same_value_key(value) -> str:
    """Text under which values a scenario would treat alike compare equal (1 and 1.0)."""
    if _is_number(value):
        return repr(float(value))
    return format_value(value)


def axes(spec: StudySpec) -> list[tuple[str, tuple]]:
    """The swept axes: (parameter, values) for [grid] then [random] parameters, in file order;
    [random] values are drawn here (deterministically).

    Raises:
        ValueError: an axis holds the same value twice.
    """
    _, fields = _scenario_fields(spec)
    out = list(spec.grid.items())
    for name in spec.random:
        default = fields[name].default if name in fields else None
        out.append((name, _draw(spec, name, default)))
    for name, values in out:
        texts = [_same_value_key(v) for v in values]
        duplicates = sorted({t for t in texts if texts.count(t) > 1})
        if duplicates:
            raise _spec_error(spec.source, spec.section_of(name),
                              f"duplicate values {duplicates}")
    return out


def format_value(value) -> str:
    """Canonical text of a parameter or metric value: floats in repr precision (exact round
    trip), bools true/false, sequences [a b c]; identical in every process."""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    if isinstance(value, str):
        return value
    if isinstance(value, (tuple, list, np.ndarray)):
        return "[" + " ".join(format_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + " ".join(f"{k}:{format_value(v)}" for k, v in sorted(value.items())) + "}"
    raise TypeError(f"cannot format {value!r} ({type(value).__name__})")


def run_key(scenario: str, params: dict, seed: int) -> str:
    """Canonical key of a run: scenario|name=value|...(sorted by name)|seed=N."""
    items = "|".join(f"{k}={format_value(v)}" for k, v in sorted(params.items()))
    return f"{scenario}|{items}|seed={int(seed)}"


def _located_error(spec: StudySpec, err: Exception, point: dict) -> ValueError:
    """A scenario's rejection of a value, attributed to the spec key that set it."""
    message = str(err)
    names = [n for n in point if re.search(rf"\b{re.escape(n)}\b", message)]
    where = (", ".join(spec.section_of(n) for n in names) if names else
             "parameter point " + ", ".join(f"{k}={format_value(v)}" for k, v in point.items()))
    return ValueError(f"{spec.source}: {where}: {message}")


def _sweep_keys(spec: StudySpec) -> str:
    return ", ".join(spec.section_of(n) for n in (*spec.grid, *spec.random)) or "[fixed]"


def expand(spec: StudySpec) -> list[Run]:
    """Validate the spec against its scenario and list its runs in table order (planner,
    pedestrian, grid/random point, seed). Every run's parameters are built once with
    `scenarios.base.make_params`, so bad values fail here with the scenario's own message.

    Raises:
        ValueError: naming the spec file and the key at fault.
    """
    from marl_social.run import randomized_overrides
    from marl_social.scenarios.base import make_params

    params_cls, fields = _scenario_fields(spec)
    _check_names(spec, params_cls, fields)
    swept = axes(spec)
    pedestrians = (None,) if "pedestrian" not in fields else (spec.pedestrians
                                                              or DEFAULT_PEDESTRIANS)
    randomized = {s: randomized_overrides(s) if spec.randomize else {} for s in spec.seeds}
    runs, seen = [], set()
    for planner, pedestrian in itertools.product(spec.planners, pedestrians):
        for values in itertools.product(*(v for _, v in swept)):
            point = {**spec.fixed, **dict(zip((n for n, _ in swept), values)),
                     "robot_planner": planner}
            if pedestrian is not None:
                point["pedestrian"] = pedestrian
            for seed in spec.seeds:
                overrides = {**randomized[seed], **point}
                try:
                    params = make_params(params_cls, overrides)
                except (TypeError, ValueError) as err:
                    raise _located_error(spec, err, point) from None
                clean = {k: getattr(params, k) for k in overrides}
                key = run_key(spec.scenario, {k: clean[k] for k in point}, seed)
                if key in seen:  # values the scenario normalizes alike
                    raise ValueError(f"{spec.source}: {_sweep_keys(spec)}: two parameter "
                                     f"points give the same run {key!r}")
                seen.add(key)
                runs.append(Run(key, clean, seed))
    return runs


def result_columns(spec: StudySpec) -> list[str]:
    """Columns of results.csv."""
    return [*HEAD_COLUMNS, *spec.param_names, *spec.metrics, *TAIL_COLUMNS]


def default_out(name: str) -> Path:
    """Default output folder of a study: marl_social_out/studies/<name>/."""
    return DEFAULT_OUT_ROOT / name


# ---------------------------------------------------------------------------- running runs


def _error_text(err: BaseException) -> str:
    text = re.sub(r"\s+", " ", f"{type(err).__name__}: {err}").strip()
    return text if len(text) <= _MAX_ERROR_CHARS else text[: _MAX_ERROR_CHARS - 3] + "..."


def _plain(value):
    """A metric value as a plain Python bool / int / float (pickles and formats the same)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    return float(value)


def run_job(job: tuple) -> tuple[str, dict | None, str | None, float]:
    """Run one study job (key, scenario, seed, max_cycles, overrides, metrics) in this process.

    Returns (key, metric values or None, error text or None, elapsed wall time [s]). Any
    exception of the episode is caught and returned as "TypeName: message".
    """
    key, scenario, seed, max_cycles, overrides, metrics = job
    from marl_social import run  # looked up per call: tests may patch run.run_episode

    start = time.perf_counter()
    try:
        result = run.run_episode(scenario, seed=seed, max_cycles=max_cycles, **overrides)
        missing = [m for m in metrics if m not in result.metrics]
        if missing:
            raise KeyError(f"run_episode returned no metric(s) {missing}")
        values, error = {m: _plain(result.metrics[m]) for m in metrics}, None
    except Exception as err:  # noqa: BLE001  (a failed run is recorded; the study goes on)
        values, error = None, _error_text(err)
    return key, values, error, time.perf_counter() - start


def _local_results(jobs: list[tuple], workers: int) -> Iterator[tuple]:
    """Results of jobs as they finish: in process for 1 worker, else a spawn process pool."""
    if workers == 1 or len(jobs) <= 1:
        yield from map(run_job, jobs)
        return
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    pool = ProcessPoolExecutor(min(workers, len(jobs)), mp_context=mp.get_context("spawn"))
    try:
        futures = [pool.submit(run_job, job) for job in jobs]
        for future in as_completed(futures):
            yield future.result()
    finally:  # an interrupted study cancels what has not started
        pool.shutdown(wait=True, cancel_futures=True)


def _import_ray():
    try:
        import ray
    except ImportError as err:
        raise ImportError("the Ray backend needs Ray: pip install marl-social[ray]") from err
    return ray


def _ray_init(ray, address: str | None, workers: int) -> bool:
    """Connect to (or start) Ray; True if this call started it (and must shut it down)."""
    if ray.is_initialized():
        return False
    if address is not None:
        ray.init(address=address, logging_level="WARNING")
        return True
    try:
        ray.init(address="auto", logging_level="WARNING")
    except ConnectionError:
        ray.init(num_cpus=workers, include_dashboard=False, logging_level="WARNING")
    return True


def _ray_results(jobs: list[tuple], workers: int, address: str | None) -> Iterator[tuple]:
    """Results of jobs as they finish, one Ray task per job (at most 2 per CPU in flight); a
    task that fails inside Ray (e.g. its worker crashed) yields an error result."""
    ray = _import_ray()
    started = _ray_init(ray, address, workers)
    try:
        remote = ray.remote(num_cpus=1)(run_job)
        window = max(2 * int(ray.cluster_resources().get("CPU", workers)), 2)
        queue, pending = iter(jobs), {}
        for job in itertools.islice(queue, window):
            pending[remote.remote(job)] = job
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                job = pending.pop(ref)
                try:
                    yield ray.get(ref)
                except ray.exceptions.RayError as err:
                    yield job[0], None, _error_text(err), float("nan")
                for nxt in itertools.islice(queue, 1):
                    pending[remote.remote(nxt)] = nxt
    finally:
        if started:
            ray.shutdown()


def execute(jobs: list[tuple], workers: int = 1, backend: str = "local",
            address: str | None = None) -> Iterator[tuple]:
    """Run jobs (see `run_job`) on a backend; yields results in completion order."""
    if backend == "ray":
        return _ray_results(jobs, workers, address)
    return _local_results(jobs, workers)


# ------------------------------------------------------------------------- the results table


def read_results(path: str | os.PathLike, repair: bool = False) -> tuple[list[str], list[dict]]:
    """Read results.csv: (columns, rows as dicts of strings). A last line without its newline
    (the writer was killed mid-row) is ignored; with repair=True it is also cut from the file.

    Raises:
        ValueError: a row with the wrong number of fields or a duplicate key.
    """
    path = Path(path)
    data = path.read_bytes()
    cut = data.rfind(b"\n") + 1
    if repair and cut < len(data):
        with open(path, "r+b") as f:
            f.truncate(cut)
            f.flush()
            os.fsync(f.fileno())
    reader = csv.reader(io.StringIO(data[:cut].decode("utf-8"), newline=""))
    header = next(reader, [])
    rows, keys = [], set()
    for line, fields in enumerate(reader, start=2):
        if len(fields) != len(header):
            raise ValueError(f"{path}:{line}: {len(fields)} fields, the header has "
                             f"{len(header)}")
        row = dict(zip(header, fields))
        if row["key"] in keys:
            raise ValueError(f"{path}:{line}: duplicate key {row['key']!r}")
        keys.add(row["key"])
        rows.append(row)
    return header, rows


def _write_table(path: Path, columns: list[str], rows: Iterable[dict]) -> None:
    """Replace the table atomically (temporary file, fsync, rename)."""
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=columns, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


@contextmanager
def _appender(path: Path, columns: list[str], keys: Iterable[str]) -> Iterator:
    """Yields write(row): appends a row to results.csv, flushed and fsynced, and refuses a key
    written before. Writes the header into a new (or empty) file."""
    new = not path.exists() or path.stat().st_size == 0
    written = set(keys)
    with open(path, "a", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=columns, lineterminator="\n")

        def sync() -> None:
            f.flush()
            os.fsync(f.fileno())

        def write(row: dict) -> None:
            if row["key"] in written:
                raise RuntimeError(f"duplicate key {row['key']!r} (a bug: already written)")
            writer.writerow(row)
            sync()
            written.add(row["key"])

        if new:
            writer.writeheader()
            sync()
        yield write


def _row(spec: StudySpec, run: Run, values: dict | None, error: str | None,
         elapsed_s: float) -> dict:
    row = {"key": run.key, "seed": str(run.seed), "planner": run.overrides["robot_planner"],
           "pedestrian": run.overrides.get("pedestrian", "")}
    row.update({p: format_value(run.overrides[p]) for p in spec.param_names})
    row.update({m: format_value(values[m]) if values else "" for m in spec.metrics})
    row["error"] = error or ""
    row["elapsed_s"] = f"{elapsed_s:.3f}"
    return row


def study_metadata(spec: StudySpec) -> dict:
    """The resolved spec as written to study.json (read by the analysis and by resume)."""
    return {
        "name": spec.name, "source": spec.source, "description": spec.description,
        "scenario": spec.scenario, "max_cycles": spec.max_cycles, "randomize": spec.randomize,
        "sample_seed": spec.sample_seed, "seeds": list(spec.seeds),
        "planners": list(spec.planners),
        "pedestrians": None if spec.pedestrians is None else list(spec.pedestrians),
        "fixed": spec.fixed, "grid": spec.grid, "random": spec.random,
        "axes": {name: list(values) for name, values in axes(spec)},
        "params": spec.param_names, "metrics": list(spec.metrics),
        "columns": result_columns(spec),
    }


def _check_meta(out_dir: Path, meta: dict) -> None:
    """Refuse to resume into a folder holding a different study."""
    path = out_dir / META_FILE
    if not path.exists():
        return
    old = json.loads(path.read_text(encoding="utf-8"))
    for key in ("scenario", "max_cycles", "randomize", "columns"):
        if old.get(key) != meta[key]:
            raise ValueError(f"{path}: this folder holds a study with {key}={old.get(key)!r}, "
                             f"the spec gives {meta[key]!r}; use another --out or --overwrite")


def _clear_outputs(out_dir: Path) -> None:
    """Delete what a study writes into out_dir (--overwrite)."""
    from marl_social.study_analysis import PLOTS_DIR, SUMMARY_CSV, SUMMARY_MD

    for name in (RESULTS_FILE, META_FILE, SUMMARY_MD, SUMMARY_CSV):
        (out_dir / name).unlink(missing_ok=True)
    plots = out_dir / PLOTS_DIR
    if plots.is_dir():
        for png in plots.glob("*.png"):
            png.unlink()


def _prepare_table(path: Path, columns: list[str], retry_failed: bool) -> dict[str, dict]:
    """Finished rows of an existing table by key (failed ones removed if retry_failed)."""
    if not path.exists():
        return {}
    header, rows = read_results(path, repair=True)
    if header and header != columns:
        raise ValueError(f"{path}: its columns {header} differ from the spec's {columns}; use "
                         "another --out or --overwrite")
    if retry_failed and any(r["error"] for r in rows):
        rows = [r for r in rows if not r["error"]]
        _write_table(path, columns, rows)
    return {r["key"]: r for r in rows}


def _finalize(path: Path, columns: list[str], runs: list[Run]) -> None:
    """Rewrite the table in the spec's run order (rows of other runs, e.g. more seeds from an
    earlier resume, follow sorted by key)."""
    _, rows = read_results(path)
    order = {r.key: i for i, r in enumerate(runs)}
    rows.sort(key=lambda r: (order.get(r["key"], len(order)), r["key"]))
    _write_table(path, columns, rows)


@contextmanager
def _exclusive(out_dir: Path) -> Iterator[None]:
    """Hold an exclusive lock on out_dir (POSIX flock on .study.lock, released even on
    SIGKILL) so that two processes never run a study into the same folder."""
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield
        return
    with open(out_dir / LOCK_FILE, "a") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise RuntimeError(f"{out_dir}: another process is running a study into this "
                               "folder") from None
        yield


def _prepare_out(spec: StudySpec, out_dir: Path, resume: bool, overwrite: bool,
                 retry_failed: bool) -> dict[str, dict]:
    """Check out_dir against the spec, clear it (overwrite) or read its finished rows
    (resume), write study.json; returns the finished rows by key."""
    table = out_dir / RESULTS_FILE
    if table.exists() and not (resume or overwrite):
        raise FileExistsError(f"{table} exists: pass --resume to continue the study or "
                              "--overwrite to start it again")
    if overwrite:
        _clear_outputs(out_dir)
    meta = study_metadata(spec)
    _check_meta(out_dir, meta)
    done = _prepare_table(table, meta["columns"], retry_failed)
    (out_dir / META_FILE).write_text(json.dumps(meta, indent=2, default=str) + "\n")
    return done


def run_study(spec: StudySpec | str | os.PathLike, out: str | os.PathLike | None = None, *,
              workers: int = 1, backend: str = "local", address: str | None = None,
              resume: bool = False, retry_failed: bool = False, overwrite: bool = False,
              seeds: int | None = None, progress: bool = True, analyze: bool = True,
              plots: bool = True) -> StudyOutcome:
    """Run a study (a StudySpec, a spec file or a built-in name) into `out`
    (default marl_social_out/studies/<name>/), writing results.csv row by row.

    Args:
        workers: parallel episodes (local processes, or the CPUs of a new local Ray).
        backend: "local" or "ray" (see the module docstring).
        address: Ray cluster address (backend "ray").
        resume: keep the finished rows of an existing results.csv, run the rest.
        retry_failed: with resume, also run again the runs recorded with an error.
        overwrite: delete an existing study's outputs in `out` first.
        seeds: use range(seeds) instead of the spec's seeds.
        progress: show a tqdm progress bar with ETA.
        analyze, plots: write summary.md / summary.csv (and the plots) at the end.

    Raises:
        ValueError: invalid spec or arguments, or `out` holds a different study.
        FileExistsError: results.csv exists and neither resume nor overwrite is set.
        RuntimeError: another process is running a study into `out`.
    """
    if not isinstance(spec, StudySpec):
        spec = load_spec(spec, validate=False)
    if seeds is not None:
        spec = with_seeds(spec, seeds)
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if not _is_int(workers) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if resume and overwrite:
        raise ValueError("choose one of resume and overwrite")
    runs = expand(spec)
    if backend == "ray":
        _import_ray()
    out_dir = Path(out) if out is not None else default_out(spec.name)
    table = out_dir / RESULTS_FILE
    out_dir.mkdir(parents=True, exist_ok=True)
    with _exclusive(out_dir):
        done = _prepare_out(spec, out_dir, resume, overwrite, retry_failed)
        n_errors = _execute_into(spec, runs, done, table, result_columns(spec), workers,
                                 backend, address, progress)
        _finalize(table, result_columns(spec), runs)
    todo = sum(r.key not in done for r in runs)
    outcome = StudyOutcome(out_dir, table, len(runs), len(runs) - todo, todo, n_errors)
    if analyze:
        from marl_social.study_analysis import analyze as analyze_study

        outcome.analysis = analyze_study(out_dir, plots=plots)
    return outcome


def _execute_into(spec: StudySpec, runs: list[Run], done: dict, table: Path,
                  columns: list[str], workers: int, backend: str, address: str | None,
                  progress: bool) -> int:
    """Run what is not done yet (seed-major order), appending rows; returns the error count."""
    from tqdm import tqdm

    seed_rank = {s: i for i, s in enumerate(spec.seeds)}
    todo = sorted((r for r in runs if r.key not in done), key=lambda r: seed_rank[r.seed])
    by_key = {r.key: r for r in todo}
    jobs = [(r.key, spec.scenario, r.seed, spec.max_cycles, r.overrides, spec.metrics)
            for r in todo]
    n_errors = 0
    with _appender(table, columns, done) as write, tqdm(
            total=len(runs), initial=len(runs) - len(todo), desc=f"study {spec.name}",
            unit="run", disable=not progress or not todo, dynamic_ncols=True) as bar:
        for key, values, error, elapsed_s in execute(jobs, workers, backend, address):
            write(_row(spec, by_key[key], values, error, elapsed_s))
            n_errors += error is not None
            bar.update(1)
            if n_errors:
                bar.set_postfix(errors=n_errors)
    return n_errors


# --------------------------------------------------------------------------------------- CLI


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The `study` command's arguments."""
    parser.add_argument("spec", nargs="?", help="built-in study name (see --list) or a TOML "
                        "spec file")
    parser.add_argument("--out", help="output folder (default marl_social_out/studies/<name>)")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                        help="parallel episodes (default: the number of CPUs)")
    parser.add_argument("--backend", choices=BACKENDS, default="local")
    parser.add_argument("--address", help="Ray cluster address (default: the running cluster "
                        "or a new local Ray)")
    parser.add_argument("--resume", action="store_true",
                        help="keep the finished runs of an existing results.csv")
    parser.add_argument("--retry-failed", action="store_true", help="with --resume, run again "
                        "the runs recorded with an error (by default they count as finished)")
    parser.add_argument("--overwrite", action="store_true",
                        help="delete the existing study in --out first")
    parser.add_argument("--seeds", type=int, help="use seeds 0..N-1 instead of the spec's")
    parser.add_argument("--no-plots", action="store_true", help="summary tables only")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--analyze-only", action="store_true",
                        help="only (re)write the plots and summary of an existing study")
    parser.add_argument("--list", action="store_true", help="list the built-in studies")


def register_cli(subparsers) -> argparse.ArgumentParser:
    """Add the `study` subcommand to the `marl-social` CLI's subparsers."""
    parser = subparsers.add_parser(
        "study", help="run a sensitivity study (parameter sweeps x planners x seeds)",
        description=__doc__.split("\n\n")[0])
    add_arguments(parser)
    parser.set_defaults(func=cli)
    return parser


def _list_builtin() -> int:
    for name, path in builtin_specs().items():
        try:
            spec = load_spec(path, validate=False)
            n = f"{len(expand(spec))} runs"
        except ValueError as err:
            spec, n = None, f"invalid: {err}"
        description = spec.description if spec is not None else ""
        print(f"{name:<16} {n:<12} {description}")
    return 0


def cli(args: argparse.Namespace) -> int:
    """Entry of `marl-social study`; returns the exit code."""
    if args.list:
        return _list_builtin()
    if not args.spec:
        print("error: name a study (see --list) or a spec file", file=sys.stderr)
        return 2
    try:
        if args.analyze_only:
            from marl_social.study_analysis import analyze

            out = Path(args.out) if args.out else default_out(load_spec(args.spec, False).name)
            outputs = analyze(out, plots=not args.no_plots)
        else:
            outcome = run_study(
                args.spec, args.out, workers=args.workers, backend=args.backend,
                address=args.address, resume=args.resume, retry_failed=args.retry_failed,
                overwrite=args.overwrite, seeds=args.seeds, progress=not args.no_progress,
                plots=not args.no_plots)
            print(f"results: {outcome.results_path} ({outcome.n_runs} runs: "
                  f"{outcome.n_executed} run now, {outcome.n_skipped} already done, "
                  f"{outcome.n_errors} errors now)")
            outputs = outcome.analysis
    except (ValueError, RuntimeError, FileExistsError, FileNotFoundError, ImportError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(f"summary: {outputs.summary_md}")
    if outputs.figures:
        print(f"plots:   {len(outputs.figures)} in {outputs.figures[0].parent}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """`python -m marl_social.studies ...`: the same as `marl-social study ...`."""
    parser = argparse.ArgumentParser(prog="python -m marl_social.studies",
                                     description=__doc__.split("\n\n")[0])
    add_arguments(parser)
    return cli(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
