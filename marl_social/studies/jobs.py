"""Running study jobs: one episode per job, in this process or on a local process pool.

A job is a tuple (key, scenario, seed, max_cycles, overrides, metrics); `run_job` runs it and
returns (key, metric values or None, error text or None, elapsed wall time [s]). The Ray
backend is in `marl_social/studies/ray_backend.py`; `runner.execute` picks one.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import re
import time
from collections.abc import Iterator
from functools import cache
from pathlib import Path

import numpy as np

MAX_ERROR_CHARS = 500
PARENT_POLL_S = 0.25  # how often a pool worker checks that the study process still runs [s]


def error_text(err: BaseException) -> str:
    """One line "TypeName: message" of an exception, at most MAX_ERROR_CHARS characters."""
    text = re.sub(r"\s+", " ", f"{type(err).__name__}: {err}").strip()
    return text if len(text) <= MAX_ERROR_CHARS else text[: MAX_ERROR_CHARS - 3] + "..."


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
    from marl_social.evaluation import run  # looked up per call: tests may patch run.run_episode

    start = time.perf_counter()
    try:
        result = run.run_episode(scenario, seed=seed, max_cycles=max_cycles, **overrides)
        missing = [m for m in metrics if m not in result.metrics]
        if missing:
            raise KeyError(f"run_episode returned no metric(s) {missing}")
        values, error = {m: _plain(result.metrics[m]) for m in metrics}, None
    except Exception as err:  # noqa: BLE001  (a failed run is recorded; the study goes on)
        values, error = None, error_text(err)
    return key, values, error, time.perf_counter() - start


CODE_PACKAGES = ("marl_social", "marl_social.agents", "marl_social.perception")


@cache
def code_fingerprint() -> tuple[str, str]:
    """(sha256 of marl-social's Python sources, where they are) as this process imports them.

    The hash covers the relative path and bytes of every .py file of the packages in
    CODE_PACKAGES (agents/ and perception/ are mapped into marl_social by the install), so two
    processes with the same code agree wherever it is installed.
    """
    digest, places = hashlib.sha256(), []
    for name in CODE_PACKAGES:
        folder = Path(next(iter(importlib.import_module(name).__path__)))
        places.append(str(folder))
        for path in sorted(folder.rglob("*.py")):
            digest.update(f"{name}/{path.relative_to(folder).as_posix()}\0".encode())
            digest.update(path.read_bytes())
    return digest.hexdigest(), ", ".join(places)


def local_results(jobs: list[tuple], workers: int) -> Iterator[tuple]:
    """Results of jobs as they finish: in process for 1 worker, else a spawn process pool."""
    if workers == 1 or len(jobs) <= 1:
        yield from map(run_job, jobs)
        return
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    pool = ProcessPoolExecutor(min(workers, len(jobs)), mp_context=mp.get_context("spawn"),
                               initializer=die_with_parent, initargs=(os.getpid(),))
    try:
        futures = [pool.submit(run_job, job) for job in jobs]
        for future in as_completed(futures):
            yield future.result()
    finally:  # an interrupted study cancels what has not started
        pool.shutdown(wait=True, cancel_futures=True)


def die_with_parent(parent_pid: int, poll_s: float = PARENT_POLL_S) -> None:
    """Pool worker initializer: exit as soon as the study process is gone.

    A killed study (SIGKILL: no cleanup runs) would otherwise leave its workers blocked on the
    job queue forever, and with them multiprocessing's resource tracker. A daemon thread polls
    the parent pid every `poll_s` seconds and ends the worker when it changes.

    Args:
        parent_pid: pid of the process that started the pool.
        poll_s: polling period [s].
    """
    import threading

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(poll_s)
        os._exit(1)  # the parent is gone: nobody reads our results

    threading.Thread(target=watch, name="die-with-parent", daemon=True).start()
