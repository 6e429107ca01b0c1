"""Shared fixtures of the test suite (helpers to import live in tests/helpers.py)."""

from __future__ import annotations

import os

import matplotlib
import pytest

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture
def paper_env():
    import marl_social

    env = marl_social.parallel_env(scenario="occluded_crosswalk")
    yield env
    env.close()
