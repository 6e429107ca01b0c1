"""Loading a study spec, validating it against its scenario and expanding it into runs.

`load_spec` reads a TOML file or a built-in name (`marl_social/studies/specs/`) and by default
validates every run; `expand` lists the runs (grid x random axes x planners x pedestrians x
seeds) with their overrides and keys. The spec model itself is in `marl_social/studies/spec.py`.
"""

from __future__ import annotations

import collections
import dataclasses
import difflib
import itertools
import math
import os
import re
import tomllib
import zlib
from functools import cache
from importlib import resources
from pathlib import Path

import numpy as np

from marl_social.data.file_limits import MB, check_file_size
from marl_social.studies.spec import (
    DEFAULT_PEDESTRIANS,
    MAX_INT_RANGE,
    MAX_RUNS,
    MAX_SEEDS,
    SPEC_PACKAGE_DIR,
    Run,
    StudySpec,
    _is_int,
    _is_number,
    _spec_error,
    parse_spec,
)


def builtin_specs() -> dict[str, Path]:
    """Built-in study specs shipped with the package: name -> path."""
    folder = resources.files("marl_social.studies").joinpath(SPEC_PACKAGE_DIR)
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


MAX_SPEC_BYTES = 10 * MB  # largest spec file read [bytes]


def load_spec(name_or_path: str | os.PathLike, validate: bool = True) -> StudySpec:
    """Read a spec from a TOML file or a built-in name and (by default) validate it fully.

    Full validation checks structure, scenario, parameter names, planners, metrics and every
    run's parameter values.

    Raises:
        ValueError: naming the file and the key at fault.
    """
    path = _resolve_spec_path(name_or_path)
    check_file_size(path, MAX_SPEC_BYTES, "a study spec")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"{path}: malformed TOML: {err}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text (TOML) file") from None
    except IsADirectoryError:
        raise ValueError(f"{path}: is a directory, not a TOML spec file") from None
    source = str(path)
    if path.resolve() == builtin_specs().get(path.stem, Path()).resolve():
        # a built-in spec by its place in the package, not by this machine's install path
        source = f"marl_social/studies/specs/{path.name}"
    spec = parse_spec(data, source=source, default_name=path.stem)
    if validate:
        expand(spec)
    return spec


def with_seeds(spec: StudySpec, n_seeds: int) -> StudySpec:
    """The spec with seeds range(n_seeds) (the CLI's --seeds, for quick runs)."""
    if not _is_int(n_seeds) or not 1 <= n_seeds <= MAX_SEEDS:
        raise ValueError(f"--seeds: expected an integer in [1, {MAX_SEEDS}], got {n_seeds!r}")
    return dataclasses.replace(spec, seeds=tuple(range(n_seeds)))


@cache
def available_metrics(scenario: str) -> tuple[str, ...]:
    """The metric names `run_episode` returns for a scenario (the same for every scenario).

    Args:
        scenario: a registered scenario name (ValueError otherwise).

    Returns:
        The registry's metric names (`marl_social.metrics.metric_names`), in result order.
    """
    from marl_social.metrics import metric_names
    from marl_social.scenarios import SCENARIOS

    if scenario not in SCENARIOS:
        raise ValueError(f"unknown scenario {scenario!r}; available: {sorted(SCENARIOS)}")
    return metric_names()


def _scenario_fields(spec: StudySpec) -> tuple[type, dict]:
    from marl_social.scenarios import SCENARIOS

    if spec.scenario not in SCENARIOS:
        raise _spec_error(spec.source, "scenario", f"unknown scenario {spec.scenario!r}; "
                          f"available: {sorted(SCENARIOS)}")
    from marl_social.scenarios.settings_tree import settings_leaves

    cls = SCENARIOS[spec.scenario].params_cls
    # every name a spec may use: the settings tree's leaves and the flat field names
    defaults = {f.name: f.default for f in dataclasses.fields(cls)}
    defaults.update({name: leaf.default for name, leaf in settings_leaves(cls).items()})
    return cls, defaults


def _closest(name: str, names) -> str:
    """"; did you mean 'x'?" for the closest of `names` to `name`, else ""."""
    close = difflib.get_close_matches(name, list(names), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def _check_names(spec: StudySpec, params_cls: type, fields: dict) -> None:
    from marl_social.agents.registry import ROBOT_PLANNERS

    for name in spec.param_names:
        if name not in fields:
            raise _spec_error(spec.source, spec.section_of(name),
                              f"unknown parameter for scenario {spec.scenario!r} "
                              f"({params_cls.__name__}){_closest(name, fields)}; "
                              f"`marl-social params {spec.scenario}` lists them")
    bad = [p for p in spec.planners if p not in ROBOT_PLANNERS]
    if bad:
        raise _spec_error(spec.source, "planners", f"unknown planner(s) {bad}; valid: "
                          f"{list(ROBOT_PLANNERS)}")
    if spec.pedestrians is not None and "pedestrian" not in fields:
        raise _spec_error(spec.source, "pedestrians", f"scenario {spec.scenario!r} has no "
                          "pedestrian variants; remove the key")
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
        if hi_i - lo_i + 1 > MAX_INT_RANGE:
            raise _spec_error(spec.source, f"[random] {name}", f"an integer parameter: "
                              f"[{low}, {high}] spans more than {MAX_INT_RANGE:.3g} integers")
        # the same draw as rng.choice(np.arange(lo_i, hi_i + 1), ...) without the array
        return tuple(lo_i + int(v) for v in rng.choice(hi_i - lo_i + 1, n, replace=False))
    if rule.get("log", False):
        return tuple(float(v) for v in np.exp(rng.uniform(np.log(low), np.log(high), n)))
    return tuple(float(v) for v in rng.uniform(low, high, n))


def _same_value_key(value) -> str:
    """Text under which values a scenario would treat alike compare equal (1 and 1.0)."""
    if _is_number(value):
        return repr(float(value))
    return format_value(value)


def axes(spec: StudySpec) -> list[tuple[str, tuple]]:
    """The swept axes: (parameter, values) for [grid] then [random] parameters, in file order.

    [random] values are drawn here (deterministically).

    Raises:
        ValueError: an axis holds the same value twice.
    """
    _, fields = _scenario_fields(spec)
    out = list(spec.grid.items())
    for name in spec.random:
        default = fields.get(name)
        out.append((name, _draw(spec, name, default)))
    for name, values in out:
        counts = collections.Counter(_same_value_key(v) for v in values)
        duplicates = sorted(t for t, k in counts.items() if k > 1)
        if duplicates:
            raise _spec_error(spec.source, spec.section_of(name),
                              f"duplicate values {duplicates}")
    return out


def format_value(value) -> str:
    """Canonical text of a parameter or metric value, identical in every process.

    Floats in repr precision (exact round trip), bools true/false, sequences [a b c].
    """
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
    """Validate the spec against its scenario and list its runs in table order.

    Table order is planner, pedestrian, grid/random point, seed. Every run's parameters are built once with
    `scenarios.base.make_params`, so bad values fail here with the scenario's own message.

    Raises:
        ValueError: naming the spec file and the key at fault.
    """
    from marl_social.evaluation.run import scenario_randomized_overrides
    from marl_social.scenarios.base import make_params, setting_value

    params_cls, fields = _scenario_fields(spec)
    _check_names(spec, params_cls, fields)
    swept = axes(spec)
    pedestrians = (None,) if "pedestrian" not in fields else (spec.pedestrians
                                                              or DEFAULT_PEDESTRIANS)
    n_runs = len(spec.planners) * len(pedestrians) * len(spec.seeds) * math.prod(
        len(v) for _, v in swept)
    if n_runs > MAX_RUNS:
        raise ValueError(f"{spec.source}: {n_runs} runs (planners x pedestrians x "
                         f"{_sweep_keys(spec)} x seeds): at most {MAX_RUNS}")
    randomized = {s: scenario_randomized_overrides(s, spec.scenario) if spec.randomize else {}
                  for s in spec.seeds}
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
                clean = {k: setting_value(params, k) for k in overrides}
                key = run_key(spec.scenario, {k: clean[k] for k in point}, seed)
                if key in seen:  # values the scenario normalizes alike
                    raise ValueError(f"{spec.source}: {_sweep_keys(spec)}: two parameter "
                                     f"points give the same run {key!r}")
                seen.add(key)
                runs.append(Run(key, clean, seed))
    return runs
