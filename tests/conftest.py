"""Shared fixtures of the test suite (helpers to import live in tests/helpers.py)."""

from __future__ import annotations

import os
import subprocess
import sys

import matplotlib
import pytest

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")


def pytest_sessionstart(session):
    """Compile the numba kernels missing from numba's cache once, before the test workers start.

    On a fresh clone every xdist worker, and every process pool a test starts, would otherwise
    compile the same kernels at once (3-4 processes on 2 cores, ~55 s of compiling each). Here
    the planners' kernels compile in one process while the belief's and the tree solver's
    compile in another (agents/compile_kernels.py). Nothing runs when the cache is current.
    xdist starts its workers in its own (trylast) pytest_sessionstart, after this one.
    """
    if hasattr(session.config, "workerinput"):  # an xdist worker: the controller did it
        return
    from marl_social.agents.compile_kernels import parts_to_compile

    parts = parts_to_compile()
    groups = [g for g in ([p for p in parts if p == "planners"],
                          [p for p in parts if p != "planners"]) if g]
    code = "from marl_social.agents.compile_kernels import compile_kernels; compile_kernels({})"
    procs = [subprocess.Popen([sys.executable, "-c", code.format(group)]) for group in groups]
    for proc in procs:
        if proc.wait() != 0:
            raise pytest.UsageError(f"compiling the numba kernels {proc.args[-1]} failed")


def pytest_collection_modifyitems(config, items):
    """Run the files of slow tests first, each file's tests in their own order.

    With pytest-xdist's `--dist loadfile --no-loadscope-reorder` (pyproject's addopts) a file
    goes to one worker in collection order (without the flag, xdist >= 3.5 sends the files with
    the most tests first, and the few-test slow files ran last): starting the long files first
    (files marked slow as a whole, the many-seed claims with their own process pools, then
    files with some slow tests) keeps one of them from running alone at the end while the
    other workers idle.
    """
    slow = {}  # file -> [any test slow, every test slow]
    for item in items:
        is_slow = item.get_closest_marker("slow") is not None
        any_all = slow.setdefault(item.path, [False, True])
        any_all[0] |= is_slow
        any_all[1] &= is_slow
    items.sort(key=lambda item: 0 if slow[item.path][1] else 1 if slow[item.path][0] else 2)


@pytest.fixture
def paper_env():
    import marl_social

    env = marl_social.parallel_env(scenario="occluded_crosswalk")
    yield env
    env.close()
