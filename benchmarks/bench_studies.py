"""Study runner throughput: episodes per second of a study of the paper scenario.

Measured on the local backend with 1 and 2 workers and on Ray with 2 CPUs, with the parallel
efficiency eps(2 workers) / (2 eps(1 worker)).

    python benchmarks/bench_studies.py [--runs 40] [--max-cycles 150] [--planner social]

The study: `--runs` seeds of the occluded crosswalk with a crossing pedestrian, randomize = true
(run.randomized_overrides), every metric of studies.DEFAULT_METRICS. Local times include the
process pool's start (spawn, one import of marl_social per worker); Ray's start is timed apart
(ray.init before the study) and its task overhead is in the study time. The three tables are
checked to be identical (every column but elapsed_s).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from marl_social.studies import runner as studies


def _table(path: Path) -> list[tuple]:
    _, rows = studies.read_results(path)
    return sorted(tuple((k, v) for k, v in r.items() if k != "elapsed_s") for r in rows)


def _timed_study(spec: studies.StudySpec, out: Path, **kwargs) -> tuple[float, Path]:
    start = time.perf_counter()
    outcome = studies.run_study(spec, out, progress=False, analyze=False, **kwargs)
    elapsed = time.perf_counter() - start
    if outcome.n_errors:
        raise RuntimeError(f"{outcome.n_errors} runs failed: see {outcome.results_path}")
    return elapsed, outcome.results_path


def bench_studies(runs: int = 40, max_cycles: int = 150, planner: str = "social") -> dict:
    """Time the same study on the three backends; returns episodes/s and efficiencies."""
    import ray

    spec = studies.StudySpec(name="bench", seeds=tuple(range(runs)), planners=(planner,),
                             pedestrians=("crossing",), max_cycles=max_cycles, randomize=True)
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        t1, table1 = _timed_study(spec, tmp / "local1", workers=1)
        t2, table2 = _timed_study(spec, tmp / "local2", workers=2)
        start = time.perf_counter()
        ray.init(num_cpus=2, include_dashboard=False, logging_level="WARNING")
        ray_start = time.perf_counter() - start
        try:
            t_ray, table_ray = _timed_study(spec, tmp / "ray2", workers=2, backend="ray")
        finally:
            ray.shutdown()
        identical = _table(table1) == _table(table2) == _table(table_ray)
    eps1, eps2, eps_ray = runs / t1, runs / t2, runs / t_ray
    results = {
        "runs": runs, "max_cycles": max_cycles, "planner": planner,
        "local_1_worker_eps": eps1, "local_2_workers_eps": eps2, "ray_2_cpus_eps": eps_ray,
        "local_2_workers_efficiency": eps2 / (2 * eps1),
        "ray_2_cpus_efficiency": eps_ray / (2 * eps1),
        "ray_start_s": ray_start, "tables_identical": identical,
    }
    print(f"study: {runs} runs, occluded_crosswalk, planner {planner}, pedestrian crossing, "
          f"max_cycles {max_cycles}, randomize true")
    print(f"  local, 1 worker : {eps1:6.3f} episodes/s  ({t1:.1f} s)")
    print(f"  local, 2 workers: {eps2:6.3f} episodes/s  ({t2:.1f} s, pool start included), "
          f"parallel efficiency {results['local_2_workers_efficiency']:.0%}")
    print(f"  Ray, 2 CPUs     : {eps_ray:6.3f} episodes/s  ({t_ray:.1f} s; ray.init "
          f"{ray_start:.1f} s apart), parallel efficiency {results['ray_2_cpus_efficiency']:.0%}")
    print(f"  identical tables: {identical}")
    return results


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=40)
    parser.add_argument("--max-cycles", type=int, default=150)
    parser.add_argument("--planner", default="social")
    args = parser.parse_args(argv)
    bench_studies(args.runs, args.max_cycles, args.planner)


if __name__ == "__main__":
    main()
