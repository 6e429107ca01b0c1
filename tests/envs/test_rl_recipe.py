"""The RL recipe (examples/train_robot_ppo.py): a short PPO run on the robot as the learner."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "train_robot_ppo.py"


@pytest.fixture(scope="module")
def recipe():
    # skipped without the [rl] extra; imported here, not at collection: stable_baselines3
    # imports torch (~2 s), which every xdist worker would otherwise pay to collect this file
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("supersuit")
    spec = importlib.util.spec_from_file_location("train_robot_ppo", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _rollout(vec, steps=40):
    obs = [vec.reset()]
    for _ in range(steps):
        obs.append(vec.step(np.full((vec.num_envs, 2), 0.5, dtype=np.float32))[0])
    return np.array(obs)


@pytest.mark.slow  # ~4 s, ~3 of them importing torch (the recipe's stable_baselines3)
def test_seeded_vector_env_repeats_and_seeds_differ(recipe):
    """SuperSuit's ConcatVecEnv has no seed(): the recipe's wrapper seeds its resets."""
    runs = [_rollout(recipe.make_vec_env(2, seed, max_cycles=30)) for seed in (3, 3, 4)]
    np.testing.assert_array_equal(runs[0], runs[1])
    assert not np.array_equal(runs[0], runs[2])


@pytest.mark.slow  # ~10 s: 2048 PPO steps through SuperSuit
def test_a_short_ppo_run_trains_and_evaluates(recipe):
    model, vec = recipe.train(2048, n_envs=2, seed=0, max_cycles=100)
    assert model.num_timesteps >= 2048
    act = recipe.trained_policy(model, vec)
    obs, _ = recipe.robot_env(100).reset(seed=1)
    action = act(obs["robot_0"], np.random.default_rng(0))
    assert action.shape == (2,) and np.all(np.abs(action) <= 1.0)
    returns, speeds = recipe.evaluate(act, 2, max_cycles=100)
    assert returns.shape == speeds.shape == (2,) and np.all(np.isfinite(returns))
    assert np.all((speeds >= 0.0) & (speeds <= 20.0))
    assert np.all(returns <= 0.0)  # rewards are minus costs
