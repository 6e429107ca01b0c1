"""Shared fixtures and helpers for the test suite."""

from __future__ import annotations

import os

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")


def zero_actions(env) -> dict:
    """Zero action for every live agent (cars keep their speed, pedestrians stand)."""
    return {a: np.zeros(2, dtype=np.float32) for a in env.agents}


@pytest.fixture
def paper_env():
    import marl_social

    env = marl_social.parallel_env(scenario="occluded_crosswalk")
    yield env
    env.close()
