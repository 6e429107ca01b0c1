"""Shared fixtures of the test suite (helpers to import live in tests/helpers.py)."""

from __future__ import annotations

import os

import matplotlib
import pytest

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")


def pytest_collection_modifyitems(config, items):
    """Run the files of slow tests first, each file's tests in their own order.

    With pytest-xdist's `--dist loadfile` (pyproject's addopts) a file goes to one worker in
    collection order: starting the long files first (files marked slow as a whole, the
    many-seed claims with their own process pools, then files with some slow tests) keeps one
    of them from running alone at the end while the other workers idle.
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
