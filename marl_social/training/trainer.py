"""Multi-agent PPO on RLlib's current API stack (RLModule, Learner, env runners).

    from marl_social.training import TrainSettings, train
    run = train(TrainSettings(iterations=3, out="runs/x"))

One policy per role: "robot" for the robot, "human" shared by every human driver (parameter
sharing); the agents that do not learn run their built-in planners (training/env.py). Each
iteration appends one row to `<out>/progress.csv` (and TensorBoard events in `<out>/tb` where
tensorboardX is installed); every `checkpoint_every` iterations and after the last one the
algorithm is saved to `<out>/checkpoints/iter_<n>` and `resume=True` continues from the newest
of them (the log is cut back to it first).

Determinism: with a `seed`, the env runners' episodes (variants, randomization, sensor noise,
the built-in planners' sampling) and the networks' initialization are seeded, and a run with
one env runner repeats the same numbers; with several env runners the order in which their
episodes reach the learner may differ. A resumed run restores the networks, optimizer and
iteration counters, not the env runners' random streams: from the checkpoint on it is another
sample of the same training, not a bit-identical continuation.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

from marl_social.training.scene import (
    HUMAN_POLICY,
    METRIC_KEYS,
    ROBOT_POLICY,
    SceneSettings,
    policy_of,
)

RLLIB_HINT = 'RLlib training needs the [rllib] extra: pip install -e ".[rllib]"'
LOG_COLUMNS = ("iteration", "env_steps", "episodes", "return_mean", "episode_len_mean",
               *METRIC_KEYS, "iteration_s", "sample_steps_per_s", "env_runners_healthy",
               "env_runner_restarts")
INTEGER_COLUMNS = ("iteration", "env_steps", "episodes", "env_runners_healthy",
                   "env_runner_restarts")
SETTINGS_FILE = "train_settings.json"
LOG_FILE = "progress.csv"


class TrainingError(RuntimeError):
    """A training run cannot start or go on: the message says why and what to do."""


@dataclass(frozen=True)
class PPOSettings:
    """PPO's hyperparameters (RLlib's names).

    Attributes:
        train_batch_size: env steps sampled per iteration.
        minibatch_size: steps per gradient step.
        num_epochs: passes over each iteration's batch.
        lr: Adam's learning rate.
        gamma: discount per step.
        lambda_: GAE's lambda.
        entropy_coeff: entropy bonus.
        hidden: the policy and value networks' hidden layer sizes.
    """

    train_batch_size: int = 2000
    minibatch_size: int = 250
    num_epochs: int = 6
    lr: float = 3e-4
    gamma: float = 0.99
    lambda_: float = 0.95
    entropy_coeff: float = 0.0
    hidden: tuple = (64, 64)


@dataclass(frozen=True)
class TrainSettings:
    """One training run.

    Attributes:
        scene: what the env builds (training/env.py SceneSettings).
        ppo: PPO's hyperparameters.
        iterations: training iterations in total (a resumed run counts the earlier ones).
        env_runners: RLlib env runner processes (0: sample in the driver process).
        envs_per_runner: env copies each env runner steps together.
        address: a running Ray cluster (HOST:PORT, auto, ray://HOST:10001; None: a private
            local instance with `cpus` CPUs), as for studies (studies/ray_backend.py).
        checkpoint_every: save every this many iterations (and after the last one).
        out: the run's folder.
        seed: seeds the env runners and the networks (None: unseeded).
        resume: continue from the newest checkpoint in `out`.
        progress: show a progress bar.
        cpus: CPUs of a private local Ray instance (None: env_runners + 1).
    """

    scene: SceneSettings = field(default_factory=SceneSettings)
    ppo: PPOSettings = field(default_factory=PPOSettings)
    iterations: int = 10
    env_runners: int = 1
    envs_per_runner: int = 1
    address: str | None = None
    checkpoint_every: int = 10
    out: str = "runs/train"
    seed: int | None = 0
    resume: bool = False
    progress: bool = True
    cpus: int | None = None

    def __post_init__(self):
        for name in ("iterations", "checkpoint_every", "envs_per_runner"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.env_runners < 0:
            raise ValueError(f"env_runners must be >= 0, got {self.env_runners}")

    def to_json(self) -> dict:
        values = asdict(self)
        values["scene"] = self.scene.as_config()
        return values

    @classmethod
    def from_json(cls, values: dict) -> TrainSettings:
        values = dict(values)
        values["scene"] = SceneSettings.from_config(values["scene"])
        ppo = dict(values["ppo"])
        ppo["hidden"] = tuple(ppo["hidden"])
        values["ppo"] = PPOSettings(**ppo)
        return cls(**values)


@dataclass
class TrainResult:
    """What a run left: its folder, log rows, newest checkpoint."""

    out: Path
    rows: list[dict]
    checkpoint: Path | None


def import_rllib():
    """RLlib's PPO config class, or a TrainingError with the install hint."""
    try:
        import ray  # noqa: F401
        import torch  # noqa: F401
        from ray.rllib.algorithms.ppo import PPOConfig
    except ImportError as err:
        raise TrainingError(f"{RLLIB_HINT} ({err})") from None
    return PPOConfig


def _learner_policies(scene: SceneSettings) -> list[str]:
    return {"robot": [ROBOT_POLICY], "humans": [HUMAN_POLICY],
            "both": [ROBOT_POLICY, HUMAN_POLICY]}[scene.learn]


def _map_agent(agent_id, episode=None, **kwargs):
    """RLlib's policy_mapping_fn: the robot's policy or the humans' shared one."""
    return policy_of(agent_id)


def build_config(settings: TrainSettings):
    """The RLlib PPOConfig of a run (new API stack, fault-tolerant env runners)."""
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec

    from marl_social.training.callbacks import EpisodeMetrics
    from marl_social.training.env import SceneEnv

    PPOConfig = import_rllib()
    ppo, policies = settings.ppo, _learner_policies(settings.scene)
    model = DefaultModelConfig(fcnet_hiddens=list(ppo.hidden), fcnet_activation="tanh",
                               vf_share_layers=False)
    config = (
        PPOConfig()
        .environment(SceneEnv, env_config=settings.scene.as_config(),
                     disable_env_checking=True)
        .env_runners(num_env_runners=settings.env_runners,
                     num_envs_per_env_runner=settings.envs_per_runner,
                     rollout_fragment_length="auto", num_cpus_per_env_runner=1)
        .multi_agent(policies=set(policies), policy_mapping_fn=_map_agent,
                     policies_to_train=policies)
        .rl_module(rl_module_spec=MultiRLModuleSpec(rl_module_specs={
            p: RLModuleSpec(model_config=model) for p in policies}))
        .training(train_batch_size_per_learner=ppo.train_batch_size,
                  minibatch_size=ppo.minibatch_size, num_epochs=ppo.num_epochs, lr=ppo.lr,
                  gamma=ppo.gamma, lambda_=ppo.lambda_, entropy_coeff=ppo.entropy_coeff)
        .callbacks(EpisodeMetrics)
        # an env runner that dies (its process killed, its node lost) is started again as
        # an identical copy; the iteration goes on with the others meanwhile
        .fault_tolerance(restart_failed_env_runners=True, max_num_env_runner_restarts=100,
                         delay_between_env_runner_restarts_s=1.0,
                         env_runner_health_probe_timeout_s=10.0)
        .reporting(metrics_num_episodes_for_smoothing=20)
    )
    if settings.seed is not None:
        config = config.debugging(seed=int(settings.seed))
    return config


def _number(source: dict, key: str) -> float:
    """source[key] as a float; NaN where it is missing or not a number."""
    try:
        return float(source.get(key, math.nan))
    except (TypeError, ValueError):
        return math.nan


def _count(source: dict, key: str) -> int:
    """source[key] as an int; 0 where it is missing or not a number."""
    number = _number(source, key)
    return 0 if math.isnan(number) else int(number)


def log_row(iteration: int, result: dict) -> dict:
    """One CSV row (LOG_COLUMNS) from RLlib's result dict of an iteration (NaN: no value).

    The episode columns are means over the iteration's episodes (RLlib's smoothing window,
    `metrics_num_episodes_for_smoothing`); env_steps and episodes count from the run's start.
    """
    runners = result.get("env_runners", {})
    throughput = runners.get("num_env_steps_sampled_lifetime_throughput", {})
    tolerance = result.get("fault_tolerance", {})
    row = {
        "iteration": iteration,
        "env_steps": _count(result, "num_env_steps_sampled_lifetime"),
        "episodes": _count(runners, "num_episodes_lifetime"),
        "return_mean": _number(runners, "episode_return_mean"),
        "episode_len_mean": _number(runners, "episode_len_mean"),
        **{key: _number(runners, key) for key in METRIC_KEYS},
        "iteration_s": _number(result, "time_this_iter_s"),
        "sample_steps_per_s": (_number(throughput, "throughput_since_last_reduce")
                               if isinstance(throughput, dict) else math.nan),
        "env_runners_healthy": _count(tolerance, "num_healthy_workers"),
        "env_runner_restarts": _count(tolerance, "num_remote_worker_restarts"),
    }
    return row


def checkpoints(out: Path) -> list[Path]:
    """The run's checkpoints, oldest first."""
    folder = out / "checkpoints"
    return sorted(folder.glob("iter_*")) if folder.is_dir() else []


def read_log(out: Path) -> list[dict]:
    """The rows of a run's progress.csv (numbers as floats, iteration as int)."""
    path = out / LOG_FILE
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return [{k: (int(v) if k in INTEGER_COLUMNS else float(v))
                 for k, v in row.items()} for row in csv.DictReader(f)]


def _write_log(out: Path, rows: list[dict]) -> None:
    with (out / LOG_FILE).open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=LOG_COLUMNS)
        writer.writeheader()
        writer.writerows(rows)


def _append_log(out: Path, row: dict) -> None:
    with (out / LOG_FILE).open("a", newline="") as f:
        csv.DictWriter(f, fieldnames=LOG_COLUMNS).writerow(row)


def _tensorboard(out: Path):
    try:
        from tensorboardX import SummaryWriter
    except ImportError:
        return None
    return SummaryWriter(str(out / "tb"))


def _start(settings: TrainSettings, out: Path):
    """(algorithm, iterations done, log rows so far): new, or restored from a checkpoint."""
    from ray.rllib.algorithms.algorithm import Algorithm

    saved = checkpoints(out)
    if settings.resume and saved:
        algo = Algorithm.from_checkpoint(str(saved[-1].resolve()))
        done = int(saved[-1].name.split("_")[-1])
        rows = [r for r in read_log(out) if r["iteration"] <= done]
        _write_log(out, rows)
        return algo, done, rows
    out.mkdir(parents=True, exist_ok=True)
    (out / SETTINGS_FILE).write_text(json.dumps(settings.to_json(), indent=2))
    _write_log(out, [])
    return build_config(settings).build_algo(), 0, []


def _check_out(settings: TrainSettings, out: Path) -> None:
    """A TrainingError unless `out` is new, or holds a run to resume with these settings."""
    if not settings.resume:
        if checkpoints(out) or (out / LOG_FILE).exists():
            raise TrainingError(f"{out} already holds a run: pass --resume to continue it or "
                                "another --out")
        return
    if not checkpoints(out):
        raise TrainingError(f"--resume: no checkpoint in {out / 'checkpoints'} to resume from")
    if (out / SETTINGS_FILE).exists():
        saved = TrainSettings.from_json(json.loads((out / SETTINGS_FILE).read_text()))
        if saved.scene != settings.scene or saved.ppo != settings.ppo:
            raise TrainingError(f"--resume: {out} was trained on other scene or PPO settings "
                                f"({out / SETTINGS_FILE})")


def train(settings: TrainSettings) -> TrainResult:
    """Run (or resume) a training run; returns its folder, log rows and newest checkpoint.

    Raises:
        TrainingError: RLlib missing, a run already in `out` without resume, no checkpoint
            to resume from, or the Ray cluster unreachable (one line each).
    """
    import_rllib()
    import ray

    from marl_social.studies.ray_backend import RayConnectionError, connect

    out = Path(settings.out)
    _check_out(settings, out)
    cpus = settings.cpus or settings.env_runners + 1
    try:
        started = connect(ray, settings.address, cpus)
    except RayConnectionError as err:
        raise TrainingError(str(err)) from None
    algo = None
    try:
        algo, done, rows = _start(settings, out)
        writer = _tensorboard(out)
        bar = _progress_bar(settings, done)
        for iteration in range(done + 1, settings.iterations + 1):
            row = log_row(iteration, algo.train())
            rows.append(row)
            _append_log(out, row)
            if writer is not None:
                for key, v in row.items():
                    if key != "iteration" and not math.isnan(float(v)):
                        writer.add_scalar(key, v, row["env_steps"])
                writer.flush()
            if iteration % settings.checkpoint_every == 0 or iteration == settings.iterations:
                algo.save_to_path(str((out / "checkpoints" / f"iter_{iteration:06d}").resolve()))
            if bar is not None:
                bar.update(1)
                bar.set_postfix(ret=f"{row['return_mean']:.3g}", steps=row["env_steps"])
        if bar is not None:
            bar.close()
        if writer is not None:
            writer.close()
    finally:
        if algo is not None:
            algo.stop()
        if started:
            ray.shutdown()
    saved = checkpoints(out)
    return TrainResult(out, rows, saved[-1] if saved else None)


def _progress_bar(settings: TrainSettings, done: int):
    if not settings.progress:
        return None
    from tqdm import tqdm

    return tqdm(total=settings.iterations, initial=done, desc="iterations", unit="it")
