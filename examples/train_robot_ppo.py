"""Train the robot with PPO among the built-in humans and pedestrian; compare it with random.

The robot is the only learner: `autopilot(env, controlled=["robot_0"])` drives every other agent
with its built-in policy, `homogeneous_spaces` gives the robot the normalized action space
Box(-1, 1, (2,)) (marl_social/envs/homogeneous.py), SuperSuit turns the env into a vector env
and stable-baselines3's PPO learns from it. The robot's reward is the env's: minus its own
step cost -(theta . phi) (marl_social/sim/costs.py), minus the collision penalty.

    pip install "marl-social[rl]"
    python examples/train_robot_ppo.py --steps 30000 --eval-episodes 20

It prints the mean episode return of a uniformly random policy and of the trained one over the
same evaluation seeds (disjoint from the training seeds).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import supersuit as ss
from stable_baselines3 import PPO
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.vec_env import VecEnvWrapper, VecMonitor, VecNormalize

import marl_social
from marl_social.envs.homogeneous import homogeneous_spaces
from marl_social.sim.observation import EGO_INDEX

ROBOT = "robot_0"
EVAL_SEED0 = 10_000  # evaluation episodes use seeds from here on (training uses 0, 1, ...)


def robot_env(max_cycles: int = 200, **overrides):
    """The robot-only ParallelEnv: built-in policies for every other agent, actions in [-1, 1].

    Args:
        max_cycles: the episode's step limit.
        **overrides: scenario parameters (marl-social params occluded_crosswalk).
    """
    env = marl_social.parallel_env(max_cycles=max_cycles, **overrides)
    return homogeneous_spaces(marl_social.autopilot(env, controlled=[ROBOT]))


class SeededVecEnv(VecEnvWrapper):
    """SuperSuit's SB3 vector env with `seed` (its ConcatVecEnv has none).

    `seed(s)` is kept for the next reset, which seeds copy i with s + i; later resets (the
    automatic ones after each episode) continue each copy's seeded streams.
    """

    def __init__(self, venv):
        super().__init__(venv)
        self._seed = None

    def get_attr(self, attr_name, indices=None):
        if attr_name == "render_mode":  # SuperSuit's copies have none to report: no rendering
            return [None] * self.num_envs
        return self.venv.get_attr(attr_name, indices)

    def seed(self, seed: int | None = None):
        self._seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def reset(self):
        if self._seed is None:
            return self.venv.reset()
        obs, self.venv.reset_infos = self.venv.venv.reset(seed=self._seed)
        self._seed = None
        return obs

    def step_wait(self):
        return self.venv.step_wait()


def make_vec_env(n_envs: int = 4, seed: int = 0, max_cycles: int = 200, **overrides):
    """`n_envs` copies of robot_env as one SB3 VecEnv, seeded with seed, seed + 1, ...

    Monitored (episode returns in the infos), observations and rewards normalized.

    Args:
        n_envs: env copies stepped together.
        seed: the first copy's seed.
        max_cycles: the episode's step limit.
        **overrides: scenario parameters.
    """
    vec = ss.pettingzoo_env_to_vec_env_v1(robot_env(max_cycles, **overrides))
    vec = ss.concat_vec_envs_v1(vec, n_envs, num_cpus=0, base_class="stable_baselines3")
    vec = SeededVecEnv(vec)
    vec.seed(seed)
    return VecNormalize(VecMonitor(vec), norm_obs=True, norm_reward=True, gamma=0.99)


def train(steps: int, n_envs: int = 4, seed: int = 0, max_cycles: int = 200,
          **overrides) -> tuple[PPO, VecNormalize]:
    """PPO on the robot for `steps` env steps; returns the model and its normalizing env.

    Args:
        steps: total env steps over all copies.
        n_envs: env copies stepped together.
        seed: seeds the envs, the policy's initialization and its sampling.
        max_cycles: the episode's step limit.
        **overrides: scenario parameters.
    """
    vec = make_vec_env(n_envs, seed, max_cycles, **overrides)
    model = PPO("MlpPolicy", vec, n_steps=256, batch_size=256, n_epochs=10, learning_rate=3e-4,
                gamma=0.99, gae_lambda=0.95, ent_coef=0.0, seed=seed, device="cpu", verbose=0)
    # no log output: SB3's default logger makes an empty folder in the temp dir on every run
    model.set_logger(Logger(folder=None, output_formats=[]))
    model.learn(total_timesteps=steps)
    return model, vec


def evaluate(act, n_episodes: int, max_cycles: int = 200, seed0: int = EVAL_SEED0,
             **overrides) -> tuple[np.ndarray, np.ndarray]:
    """The robot's undiscounted returns and mean speeds under `act(obs, rng) -> action`.

    Args:
        act: the robot's policy: its (obs_dim,) observation and a generator -> (2,) action in
            [-1, 1].
        n_episodes: episodes, seeded seed0, seed0 + 1, ...
        max_cycles: the episode's step limit.
        seed0: the first episode's seed.
        **overrides: scenario parameters.

    Returns:
        (n_episodes,) returns and (n_episodes,) mean speeds [m/s] (from the robot's odometry).
    """
    env = robot_env(max_cycles, **overrides)
    returns, speeds = np.zeros(n_episodes), np.zeros(n_episodes)
    for k in range(n_episodes):
        rng = np.random.default_rng(seed0 + k)
        obs, _ = env.reset(seed=seed0 + k)
        v = []
        while env.agents:
            v.append(obs[ROBOT][EGO_INDEX["v"]])
            obs, rew, *_ = env.step({ROBOT: act(obs[ROBOT], rng)})
            returns[k] += rew[ROBOT]
        speeds[k] = np.mean(v)
    return returns, speeds


def random_policy(obs: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A uniformly random normalized action."""
    return rng.uniform(-1.0, 1.0, size=2)


def trained_policy(model: PPO, vec: VecNormalize):
    """The trained robot as `act(obs, rng)`: deterministic PPO on normalized observations."""
    def act(obs: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        action, _ = model.predict(vec.normalize_obs(obs[None]), deterministic=True)
        return action[0]

    return act


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--steps", type=int, default=30_000, help="PPO env steps")
    parser.add_argument("--envs", type=int, default=4, help="env copies stepped together")
    parser.add_argument("--eval-episodes", type=int, default=20, help="evaluation episodes")
    parser.add_argument("--max-cycles", type=int, default=200, help="episode step limit")
    parser.add_argument("--seed", type=int, default=0, help="training seed")
    parser.add_argument("--pedestrian", default="crossing", help="crossing, waiting or none")
    args = parser.parse_args(argv)
    scenario = {"pedestrian": args.pedestrian}

    t0 = time.perf_counter()
    model, vec = train(args.steps, args.envs, args.seed, args.max_cycles, **scenario)
    t_train = time.perf_counter() - t0
    rand, v_rand = evaluate(random_policy, args.eval_episodes, args.max_cycles, **scenario)
    ppo, v_ppo = evaluate(trained_policy(model, vec), args.eval_episodes, args.max_cycles,
                          **scenario)
    print(f"PPO: {args.steps} steps in {t_train:.0f} s; {args.eval_episodes} evaluation "
          f"episodes (seeds {EVAL_SEED0}...):")
    for name, ret, v in (("random", rand, v_rand), ("trained", ppo, v_ppo)):
        print(f"  {name:<8} policy  mean return {ret.mean():10.1f} (std {ret.std():7.1f})   "
              f"mean speed {v.mean():5.2f} m/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
