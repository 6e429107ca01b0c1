"""A trained robot policy as a planner, and the reproduce table of a checkpoint.

    planner = LearnedPlanner.from_checkpoint("runs/x/checkpoints/iter_000003", spec, layout,
                                             road_map, agent_names)
    rows = evaluate_checkpoint("runs/x/checkpoints/iter_000003", n_seeds=20)

`LearnedPlanner` follows the planner protocol (agents/base.py): it is built from the robot's
spec, the layout and the static map, and each call sees only the robot's own observation. With
a run trained on `observation="ego+belief"` it keeps its own social belief
(envs/belief_observation.py `BeliefFeatures`, the social planner's belief) from those
observations, as the env did in training. It acts deterministically: the mean of the trained
Gaussian, clipped to [-1, 1] and mapped to the robot's units as in training.

`evaluate_checkpoint` runs the learned robot on the occluded crosswalk's variants over
randomized seeds (the reproduce table's "wide" randomization), next to built-in planners (run
by `run_episode`, the reproduce table's own episodes), and returns the reproduce table's rows.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from marl_social.envs.belief_observation import BeliefFeatures
from marl_social.envs.parallel import parallel_env
from marl_social.envs.policies import policies
from marl_social.evaluation.reproduce import (
    VARIANTS,
    map_jobs,
    run_episodes,
    summarize,
    table_rows,
)
from marl_social.evaluation.rollout import record_episode
from marl_social.evaluation.run import randomized_overrides
from marl_social.metrics.episode import episode_metrics
from marl_social.training.scene import (
    ROBOT,
    ROBOT_POLICY,
    Actuator,
    ObservationScaler,
    SceneSettings,
    template_env,
)
from marl_social.training.trainer import SETTINGS_FILE, TrainingError, TrainSettings, import_rllib

EVAL_SEED0 = 100_000  # evaluation seeds start here (training draws its own at random)
LEARNED = "learned"  # the learned robot's row in the table


def run_settings(checkpoint: Path) -> TrainSettings:
    """The TrainSettings of the run a checkpoint belongs to (<out>/train_settings.json)."""
    checkpoint = Path(checkpoint)
    if not (checkpoint / "rllib_checkpoint.json").exists():
        raise TrainingError(f"{checkpoint}: not an RLlib checkpoint (expected "
                            "<out>/checkpoints/iter_<n> of `marl-social train`)")
    path = checkpoint.parent.parent / SETTINGS_FILE
    if not path.exists():
        raise TrainingError(f"{checkpoint}: its run's {SETTINGS_FILE} is missing ({path})")
    return TrainSettings.from_json(json.loads(path.read_text()))


_MODULES: dict = {}  # (checkpoint, policy) -> RLModule, loaded once per process


def load_module(checkpoint: Path, policy: str = ROBOT_POLICY):
    """The trained RLModule of `policy` in a checkpoint (torch, inference on CPU)."""
    key = (str(Path(checkpoint).resolve()), policy)
    if key not in _MODULES:
        _MODULES[key] = _load_module(Path(checkpoint), policy)
    return _MODULES[key]


def _load_module(checkpoint: Path, policy: str):
    import_rllib()
    from ray.rllib.core.rl_module.rl_module import RLModule

    path = Path(checkpoint) / "learner_group" / "learner" / "rl_module" / policy
    if not path.exists():
        raise TrainingError(f"{checkpoint}: holds no trained {policy!r} policy ({path})")
    return RLModule.from_checkpoint(str(path.resolve()))


class LearnedPlanner:
    """A trained RLModule as the robot's planner (the planner protocol of agents/base.py).

    Args:
        module: the trained RLModule (torch).
        scaler: the observation scaling of training (training/scene.py ObservationScaler).
        actuator: the robot's action mapping of training (training/scene.py Actuator).
        features: the belief features of an "ego+belief" run (None: "ego").
    """

    needs_truth = False

    def __init__(self, module, scaler: ObservationScaler, actuator: Actuator,
                 features: BeliefFeatures | None = None):
        import torch

        self.module, self.scaler, self.features = module, scaler, features
        self.actuator = actuator
        self._torch = torch
        self._dist = module.get_inference_action_dist_cls()
        self.belief = features.belief if features is not None else None

    @classmethod
    def from_checkpoint(cls, checkpoint, spec, layout, road_map, agent_names) -> LearnedPlanner:
        """The planner of a checkpoint for the robot `spec` (a planner's own inputs only).

        Args:
            checkpoint: <out>/checkpoints/iter_<n> of a run that trained the robot.
            spec: the robot's AgentSpec.
            layout: the shared observation layout.
            road_map: the static map.
            agent_names: the env's possible_agents (as for `make_policy`).
        """
        settings = run_settings(Path(checkpoint)).scene
        scaler = _robot_scaler(settings)
        features = (BeliefFeatures(spec, layout, road_map, agent_names)
                    if settings.observation == "ego+belief" else None)
        actuator = Actuator(spec, layout, road_map, settings.control)
        return cls(load_module(Path(checkpoint)), scaler, actuator, features)

    def reset(self, seed: int | None = None) -> None:
        """A new episode: the belief back to its prior (the policy itself is deterministic)."""
        if self.features is not None:
            self.features.reset()

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The (2,) float32 [a m/s^2, delta rad] for the robot's own observation."""
        full = obs if self.features is None else np.concatenate([obs, self.features(obs)])
        return self.act_on(full, obs)

    def act_on(self, full: np.ndarray, obs: np.ndarray) -> np.ndarray:
        """The (2,) float32 action for a full observation (with the belief features, if any).

        Args:
            full: what the policy reads: `obs` and, for "ego+belief", the belief features.
            obs: the robot's own observation (the pose the steering follows).
        """
        batch = {"obs": self._torch.from_numpy(self.scaler(full)[None])}
        with self._torch.no_grad():
            logits = self.module.forward_inference(batch)["action_dist_inputs"]
        action = self._dist.from_logits(logits).to_deterministic().sample()[0].numpy()
        return self.actuator(obs, action).astype(np.float32)


def _robot_scaler(settings: SceneSettings) -> ObservationScaler:
    env = template_env(settings)
    if ROBOT not in env.possible_agents:
        raise TrainingError(f"the run trained no robot (learn={settings.learn!r})")
    scaler = ObservationScaler(env.observation_space(ROBOT))
    env.close()
    return scaler


def learned_scene(checkpoint, variant: str, seed: int, max_cycles: int = 200):
    """(env, policies) of a randomized crosswalk episode with the learned robot.

    The env and every other agent's built-in planner as `run_episode` builds them for a
    built-in robot planner (the scene's overrides, the "wide" randomization of `seed`, the
    pedestrian `variant`), the robot's planner swapped for the checkpoint's LearnedPlanner.

    Args:
        checkpoint: <out>/checkpoints/iter_<n> of a run that trained the robot.
        variant: the pedestrian variant.
        seed: the episode's seed (its randomization too).
        max_cycles: the episode's step limit.
    """
    scene = run_settings(Path(checkpoint)).scene
    env = parallel_env(scenario=scene.scenario, max_cycles=max_cycles,
                       **{**scene.overrides, **randomized_overrides(seed, "wide"),
                          "pedestrian": variant})
    pols = policies(env)
    pols[ROBOT] = LearnedPlanner.from_checkpoint(checkpoint, env.agent_specs[ROBOT],
                                                 env.obs_layout, env.road_map,
                                                 env.possible_agents)
    return env, pols


def learned_episode(job: tuple) -> tuple:
    """One randomized crosswalk episode of the learned robot: the reproduce table's tuple.

    The episode, its trace and its metrics are those `run_episode` gives a built-in robot
    planner (the same env, seeds, policies, `record_episode` and `episode_metrics`), with the
    robot's planner swapped (`learned_scene`).

    Args:
        job: (checkpoint, variant, seed, max_cycles).

    Returns:
        ("learned", variant, seed, metrics or None, error or None).
    """
    checkpoint, variant, seed, max_cycles = job
    try:
        env, pols = learned_scene(checkpoint, variant, seed, max_cycles)
        trace = record_episode(env, pols, seed=seed)
        metrics = episode_metrics(trace, env.road_map)
        env.close()
        return LEARNED, variant, seed, metrics, None
    except Exception as err:  # noqa: BLE001  (a failed run is recorded, the table goes on)
        return LEARNED, variant, seed, None, f"{type(err).__name__}: {err}"


def evaluate_checkpoint(checkpoint, n_seeds: int = 20, variants=VARIANTS,
                        baselines=("social", "oracle"), workers: int = 1,
                        max_cycles: int = 200) -> list[dict]:
    """The reproduce table's rows of the learned robot and of built-in robot planners.

    Seeds EVAL_SEED0 ... EVAL_SEED0 + n_seeds - 1 (fresh: training draws its own), each with
    the "wide" randomization; the built-in planners' episodes are the reproduce table's
    (`run_episode`).

    Args:
        checkpoint: <out>/checkpoints/iter_<n> of a run that trained the robot.
        n_seeds: episodes per (planner, variant).
        variants: the pedestrian variants.
        baselines: built-in robot planners to run on the same episodes.
        workers: processes (1: in this process).
        max_cycles: the episodes' step limit.
    """
    checkpoint = Path(checkpoint)
    if not checkpoint.exists():
        raise TrainingError(f"checkpoint {checkpoint} does not exist")
    scene = run_settings(checkpoint).scene
    if scene.scenario != "occluded_crosswalk":
        raise TrainingError(f"train eval runs the occluded crosswalk's table; this run trained "
                            f"on {scene.scenario!r}")
    if scene.learn == "humans":
        raise TrainingError("train eval evaluates a learned robot; this run trained the humans")
    seeds = range(EVAL_SEED0, EVAL_SEED0 + n_seeds)
    jobs = [(str(checkpoint), v, s, max_cycles) for v in variants for s in seeds]
    results = map_jobs(learned_episode, jobs, workers, progress=False)
    if baselines:
        results += run_episodes([(p, v, s) for p in baselines for v in variants for s in seeds],
                                workers, max_cycles)
    return table_rows(results, (LEARNED, *baselines), variants, summarize)
