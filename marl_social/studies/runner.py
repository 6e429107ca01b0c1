"""Sensitivity studies: sweeps of scenario parameters, run on a process pool or on Ray.

A study sweeps scenario parameters x robot planners x pedestrian variants x seeds, one simulated
episode (`run.run_episode`) per run, on a local process pool or on Ray. This module runs
studies (`run_study`: one job per run, `execute` on a backend) and holds the `marl-social study`
CLI. The TOML spec format and its parsing are in `marl_social/studies/spec.py`, loading,
validation and expansion into runs in `marl_social/studies/runs.py`; the results table
(results.csv, study.json, resume) is in `marl_social/studies/results.py`, its typed copy
results.parquet and `load` (a pandas DataFrame) in `marl_social/studies/table.py`. Their public
names are re-exported here.

Backends (`marl_social/studies/jobs.py`, `marl_social/studies/ray_backend.py`): "local" runs in
process with 1 worker, else on a spawn-context process pool; "ray" sends one remote task per run
to the cluster at `address` ("HOST:PORT", "auto", "ray://..."), to the one this process is
already connected to, or else to a private local Ray instance with `workers` CPUs (shut down at
the end). Ray is optional: `pip install marl-social[ray]`; every cluster node needs marl-social
installed (docs/ray.md).

Analysis (`marl_social/studies/analysis.py`) runs at the end of a study: plots and summary.md /
summary.csv next to results.csv.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

from marl_social.envs.vector import usable_cores
from marl_social.studies.jobs import PARENT_POLL_S, die_with_parent, local_results, run_job
from marl_social.studies.ray_backend import (
    SIGTERM_EXIT_CODE,
    RayConnectionError,
    import_ray,
    ray_results,
    terminated,
)
from marl_social.studies.results import (
    DEFAULT_OUT_ROOT,
    HEAD_COLUMNS,
    LOCK_FILE,
    META_FILE,
    RESULTS_FILE,
    TAIL_COLUMNS,
    _appender,
    _exclusive,
    _finalize,
    _prepare_out,
    _row,
    default_out,
    read_results,
    result_columns,
    study_metadata,
)
from marl_social.studies.runs import (
    available_metrics,
    axes,
    builtin_specs,
    expand,
    format_value,
    load_spec,
    run_key,
    with_seeds,
)
from marl_social.studies.spec import (
    DEFAULT_MAX_CYCLES,
    DEFAULT_METRICS,
    DEFAULT_PEDESTRIANS,
    DEFAULT_PLANNERS,
    DEFAULT_SEEDS,
    SPEC_PACKAGE_DIR,
    Run,
    StudySpec,
    _is_int,
    parse_spec,
)
from marl_social.studies.table import PARQUET_FILE, load, write_parquet

# the public names of this module, marl_social.studies.spec, .runs and .results
__all__ = [
    "BACKENDS", "DEFAULT_MAX_CYCLES", "DEFAULT_METRICS", "DEFAULT_OUT_ROOT",
    "DEFAULT_PEDESTRIANS", "DEFAULT_PLANNERS", "DEFAULT_SEEDS", "EXISTING", "HEAD_COLUMNS",
    "LOCK_FILE", "META_FILE", "PARENT_POLL_S", "PARQUET_FILE", "RESULTS_FILE", "SPEC_PACKAGE_DIR",
    "SUMMARIES", "TAIL_COLUMNS", "RayConnectionError", "Run", "StudyOutcome", "StudySpec", "add_arguments",
    "available_metrics", "axes", "builtin_specs", "cli", "default_out", "die_with_parent",
    "execute", "expand", "format_value", "load", "load_spec", "main", "parse_spec",
    "read_results", "register_cli", "result_columns", "run_job", "run_key", "run_study",
    "study_metadata", "with_seeds", "write_parquet",
]

BACKENDS = ("local", "ray")
EXISTING = ("refuse", "resume", "retry_failed", "overwrite")  # a study already in the folder
SUMMARIES = ("plots", "tables", "none")  # what a study writes when its runs are done


class Execution(NamedTuple):
    """Where a study's runs execute: `workers` parallel episodes on `backend` (at `address`)."""

    workers: int
    backend: str
    address: str | None


@dataclass
class StudyOutcome:
    """What `run_study` did: the output folder and table, and counts of runs."""

    out_dir: Path
    results_path: Path
    n_runs: int  # runs in the spec
    n_skipped: int  # already in the table (resume)
    n_executed: int
    n_errors: int  # errors among the executed runs
    analysis: Any = None  # analysis.AnalysisOutputs, or None


# ---------------------------------------------------------------------------- running runs


def execute(jobs: list[tuple], workers: int = 1, backend: str = "local",
            address: str | None = None) -> Iterator[tuple]:
    """Run jobs (see `jobs.run_job`) on a backend; yields results in completion order.

    Close the iterator (or exhaust it) to stop: pending runs are cancelled.
    """
    if backend == "ray":
        return ray_results(jobs, workers, address)
    return local_results(jobs, workers)


# ----------------------------------------------------------------------------------- running a study


def run_study(spec: StudySpec | str | os.PathLike, out: str | os.PathLike | None = None, *,
              workers: int = 1, backend: str = "local", address: str | None = None,
              existing: str = "refuse", progress: bool = True,
              summary: str = "plots") -> StudyOutcome:
    """Run a study into `out`, writing results.csv row by row.

    Args:
        spec: a StudySpec, a spec file or a built-in name (`with_seeds(spec, n)` runs it on
            seeds 0..n-1 instead of its own).
        out: output folder (default marl_social_out/studies/<name>/).
        workers: parallel episodes (local processes, or the CPUs of a new local Ray).
        backend: "local" or "ray" (see the module docstring).
        address: Ray cluster address (backend "ray").
        existing: what to do with a study already in `out` (one of EXISTING): "refuse" it,
            "resume" it (keep its finished rows, run the rest), "retry_failed" (resume, and run
            again the runs recorded with an error) or "overwrite" it (delete its outputs first).
        progress: show a tqdm progress bar with ETA.
        summary: what to write at the end (one of SUMMARIES): summary.md / summary.csv and the
            "plots", the summary "tables" only, or "none".

    Raises:
        ValueError: invalid spec or arguments, or `out` holds a different study.
        FileExistsError: results.csv exists and `existing` is "refuse".
        RuntimeError: another process is running a study into `out`.
    """
    if not isinstance(spec, StudySpec):
        spec = load_spec(spec, validate=False)
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if not _is_int(workers) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if existing not in EXISTING:
        raise ValueError(f"existing must be one of {EXISTING}, got {existing!r}")
    if summary not in SUMMARIES:
        raise ValueError(f"summary must be one of {SUMMARIES}, got {summary!r}")
    runs = expand(spec)
    if backend == "ray":
        import_ray()
    out_dir = Path(out) if out is not None else default_out(spec.name)
    table = out_dir / RESULTS_FILE
    out_dir.mkdir(parents=True, exist_ok=True)
    with _exclusive(out_dir):
        done = _prepare_out(spec, out_dir, existing)
        n_errors = _execute_into(spec, runs, done, table,
                                 Execution(workers, backend, address), progress)
        _finalize(table, result_columns(spec), runs)
        write_parquet(out_dir)
    todo = sum(r.key not in done for r in runs)
    outcome = StudyOutcome(out_dir, table, len(runs), len(runs) - todo, todo, n_errors)
    if summary != "none":
        from marl_social.studies.analysis import analyze as analyze_study

        outcome.analysis = analyze_study(out_dir, plots=summary == "plots")
    return outcome


def _execute_into(spec: StudySpec, runs: list[Run], done: dict, table: Path,
                  execution: Execution, progress: bool) -> int:
    """Run what is not done yet (seed-major order), appending rows; returns the error count."""
    from tqdm import tqdm

    seed_rank = {s: i for i, s in enumerate(spec.seeds)}
    todo = sorted((r for r in runs if r.key not in done), key=lambda r: seed_rank[r.seed])
    by_key = {r.key: r for r in todo}
    jobs = [(r.key, spec.scenario, r.seed, spec.max_cycles, r.overrides, spec.metrics)
            for r in todo]
    n_errors = 0
    with _appender(table, result_columns(spec), done) as write, tqdm(
            total=len(runs), initial=len(runs) - len(todo), desc=f"study {spec.name}",
            unit="run", disable=not progress or not todo, dynamic_ncols=True) as bar, \
            contextlib.closing(execute(jobs, *execution)) as results:
        for key, values, error, elapsed_s in results:
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
    parser.add_argument("--workers", type=int, default=usable_cores(),
                        help="parallel episodes (default: the CPU cores this process may use)")
    parser.add_argument("--backend", choices=BACKENDS, default="local")
    parser.add_argument("--address", help="Ray cluster: HOST:PORT of its head, auto or "
                        "ray://HOST:PORT (default: a private local Ray; docs/ray.md)")
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
                        help="only (re)write the plots, summary and results.parquet of an "
                        "existing study")
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


def _existing(args: argparse.Namespace) -> str:
    """The `existing` mode of run_study from --resume, --retry-failed and --overwrite."""
    if args.resume and args.overwrite:
        raise ValueError("choose one of --resume and --overwrite")
    if args.retry_failed and not args.resume:
        raise ValueError("--retry-failed goes with --resume")
    if args.overwrite:
        return "overwrite"
    if args.resume:
        return "retry_failed" if args.retry_failed else "resume"
    return "refuse"


def cli(args: argparse.Namespace) -> int:
    """Entry of `marl-social study`; returns the exit code."""
    if args.list:
        return _list_builtin()
    if not args.spec:
        print("error: name a study (see --list) or a spec file", file=sys.stderr)
        return 2
    try:
        if args.analyze_only:
            from marl_social.studies.analysis import analyze

            out = Path(args.out) if args.out else default_out(load_spec(args.spec, False).name)
            outputs = analyze(out, plots=not args.no_plots)
            write_parquet(out)
        else:
            spec = load_spec(args.spec, validate=False)
            if args.seeds is not None:
                spec = with_seeds(spec, args.seeds)
            outcome = run_study(
                spec, args.out, workers=args.workers, backend=args.backend,
                address=args.address, existing=_existing(args),
                progress=not args.no_progress, summary="tables" if args.no_plots else "plots")
            print(f"results: {outcome.results_path} ({outcome.n_runs} runs: "
                  f"{outcome.n_executed} run now, {outcome.n_skipped} already done, "
                  f"{outcome.n_errors} errors now)")
            outputs = outcome.analysis
    except (ValueError, RuntimeError, FileExistsError, FileNotFoundError, ImportError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # Ctrl-C, or SIGTERM on the Ray backend
        print("interrupted: the finished runs are in results.csv; continue with --resume",
              file=sys.stderr)
        return SIGTERM_EXIT_CODE if terminated() else 130
    print(f"summary: {outputs.summary_md}")
    if outputs.figures:
        print(f"plots:   {len(outputs.figures)} in {outputs.figures[0].parent}")
    if not args.analyze_only and outcome.n_errors:
        print(f"error: {outcome.n_errors} of the {outcome.n_executed} runs run now failed (each "
              f"error is in {outcome.results_path.name}; run them again with --resume "
              "--retry-failed)", file=sys.stderr)
        return 1
    return 0


def main(argv: list[str] | None = None) -> int:
    """`python -m marl_social.studies ...`: the same as `marl-social study ...`."""
    parser = argparse.ArgumentParser(prog="python -m marl_social.studies",
                                     description=__doc__.split("\n\n")[0])
    add_arguments(parser)
    return cli(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
