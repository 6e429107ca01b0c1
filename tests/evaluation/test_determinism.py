"""Every built-in planner gives bit-identical episodes for a seed, in any process.

The robot's planner solves a QP every step: a solver whose iterations depend on wall-clock time
(OSQP's default adaptive rho) would make two runs of the same seed differ in the last bits.
"""

from __future__ import annotations

import hashlib
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import marl_social

REPO_ROOT = Path(__file__).resolve().parents[2]


def episode_digest(planner: str, seed: int) -> str:
    """sha256 of the states, actions, belief series and metrics of one seeded episode."""
    result = marl_social.run_episode("occluded_crosswalk", seed=seed, robot_planner=planner,
                                     pedestrian="crossing", max_cycles=120)
    h = hashlib.sha256()
    for array in (result.trace.states, result.trace.actions, result.trace.accel_mps2):
        h.update(np.ascontiguousarray(array).tobytes())
    for key in sorted(result.trace.extras):
        h.update(key.encode())
        h.update(np.ascontiguousarray(result.trace.extras[key]).tobytes())
    h.update(repr(sorted(result.metrics.items())).encode())
    return h.hexdigest()


@pytest.mark.slow
@pytest.mark.parametrize("planner", ["social", "conservative"])
def test_same_seed_same_episode_in_another_process(planner):
    here = [episode_digest(planner, 4), episode_digest(planner, 4)]
    code = ("from tests.evaluation.test_determinism import episode_digest; "
            f"print(episode_digest({planner!r}, 4))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=REPO_ROOT)
    assert here[0] == here[1] == out.stdout.strip()
    assert episode_digest(planner, 5) != here[0], "another seed gives another episode"
