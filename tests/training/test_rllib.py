"""Training on RLlib (training/trainer.py, learned.py, cli/train.py) with one local Ray instance
for the whole file: the log and checkpoint of a short run, resume, the learned robot as a
planner in the reproduce table, one-line errors. (A killed env runner restarted: against a real
`ray start --head` cluster, benchmarks/rllib_cluster.py; Ray takes ~30 s to restart one.)"""

from __future__ import annotations

import csv
import sys
from dataclasses import replace

import numpy as np
import pytest

from marl_social.training import PPOSettings, SceneSettings, TrainingError, TrainSettings, train
from marl_social.training.trainer import LOG_COLUMNS, RLLIB_HINT, read_log

ray = pytest.importorskip("ray", reason="needs the [rllib] extra: pip install -e '.[rllib]'")
pytest.importorskip("ray.rllib", reason="needs the [rllib] extra: pip install -e '.[rllib]'")

TINY_PPO = PPOSettings(train_batch_size=200, minibatch_size=100, num_epochs=1, hidden=(16,))
TINY_SCENE = SceneSettings(max_cycles=60, variants=("crossing", "none"), randomize="wide")


@pytest.fixture(scope="module")
def ray_session():
    """One local Ray instance for every test here (starting one takes ~5 s)."""
    ray.init(address="local", num_cpus=2, include_dashboard=False, logging_level="ERROR")
    yield
    ray.shutdown()


@pytest.fixture(scope="module")
def short_run(ray_session, tmp_path_factory):
    """A 2-iteration run with the belief observation, sampled in the driver process."""
    out = tmp_path_factory.mktemp("run")
    settings = TrainSettings(scene=replace(TINY_SCENE, observation="ego+belief"), ppo=TINY_PPO,
                             iterations=2, env_runners=0, checkpoint_every=1, out=str(out),
                             seed=0, progress=False)
    return settings, train(settings)


def test_a_short_run_writes_a_checkpoint_and_a_log_row_per_iteration(short_run):
    _, result = short_run
    with (result.out / "progress.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [int(r["iteration"]) for r in rows] == [1, 2]
    assert tuple(rows[0]) == LOG_COLUMNS
    assert [int(r["env_steps"]) for r in rows] == [200, 400]
    assert all(np.isfinite(float(r["return_mean"])) for r in rows)
    assert result.checkpoint.name == "iter_000002"
    assert (result.checkpoint / "rllib_checkpoint.json").exists()


def test_resume_continues_from_the_newest_checkpoint(short_run):
    settings, result = short_run
    with pytest.raises(TrainingError, match="already holds a run"):
        train(settings)
    resumed = train(replace(settings, iterations=3, resume=True))
    assert [r["iteration"] for r in read_log(result.out)] == [1, 2, 3]
    assert resumed.checkpoint.name == "iter_000003"
    assert resumed.rows[-1]["env_steps"] == 600  # the counters went on from the checkpoint
    with pytest.raises(TrainingError, match="other scene or PPO"):
        train(replace(settings, ppo=replace(TINY_PPO, lr=1e-3), iterations=4, resume=True))


def test_a_seeded_run_without_remote_runners_repeats_its_numbers(short_run, tmp_path):
    settings, result = short_run
    again = train(replace(settings, out=str(tmp_path / "again")))
    timing = ("iteration_s", "sample_steps_per_s")
    first, second = ([{k: v for k, v in r.items() if k not in timing} for r in rows]
                     for rows in (result.rows, again.rows))
    np.testing.assert_equal(first, second)


def test_the_learned_robot_plans_from_its_own_observation(short_run):
    from marl_social.training.learned import LearnedPlanner, learned_episode

    _, result = short_run
    env = __import__("marl_social").parallel_env(pedestrian="crossing")
    planner = LearnedPlanner.from_checkpoint(result.checkpoint, env.agent_specs["robot_0"],
                                             env.obs_layout, env.road_map, env.possible_agents)
    obs, _ = env.reset(seed=0)
    planner.reset(0)
    action = planner(obs["robot_0"])  # the shared layout only: the belief it keeps itself
    assert action.shape == (2,) and action.dtype == np.float32
    assert planner.belief is not None and len(planner.belief.probabilities) > 1
    planner_name, variant, _, metrics, error = learned_episode(
        (str(result.checkpoint), "crossing", 100_000, 40))
    assert error is None and (planner_name, variant) == ("learned", "crossing")
    assert {"robot_collision", "yielded", "hard_brake", "time_to_pass_s"} <= set(metrics)


def test_without_rllib_the_error_names_the_extra(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "ray.rllib.algorithms.ppo", None)
    with pytest.raises(TrainingError, match=r'pip install -e "\.\[rllib\]"'):
        train(TrainSettings(out=str(tmp_path)))
    assert "[rllib]" in RLLIB_HINT


def test_cli_errors_are_one_line(tmp_path, capsys):
    from marl_social.cli import main

    missing = tmp_path / "nothing" / "checkpoints" / "iter_000001"
    assert main(["train", "eval", str(missing)]) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert lines == [f"marl-social train: error: checkpoint {missing} does not exist"]
    assert main(["train", "--out", str(tmp_path / "r"), "--resume"]) == 2
    assert "no checkpoint" in capsys.readouterr().err
    assert main(["train", "--learn", "humans", "--observation", "ego+belief"]) == 2
    assert "ego+belief" in capsys.readouterr().err
