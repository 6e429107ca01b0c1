"""What a training env is made of: its settings, policies, observation scaling and scene.

The RLlib env itself (training/env.py `SceneEnv`) needs Ray; this module does not.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np
from gymnasium import spaces

from marl_social.envs.autopilot import autopilot
from marl_social.envs.belief_observation import BeliefObservationEnv
from marl_social.envs.homogeneous import from_normalized
from marl_social.envs.parallel import parallel_env
from marl_social.evaluation.run import randomized_overrides
from marl_social.models.steering import pure_pursuit

LEARNERS = ("robot", "humans", "both")  # who learns (`--learn`)
OBSERVATIONS = ("ego", "ego+belief")
CONTROLS = ("accel", "accel+steer")  # what a learner's action sets (`--control`)
ROBOT = "robot_0"
ROBOT_POLICY, HUMAN_POLICY = "robot", "human"  # the policies' ids (one shared by the humans)
METRIC_KEYS = ("robot_collision", "hard_brake", "yielded", "time_to_pass_s")


@dataclass(frozen=True)
class SceneSettings:
    """What RLlib's env builds (its env_config, as a dict: `asdict`).

    Attributes:
        scenario: a registered scenario name.
        learn: "robot" (the robot among the built-in humans), "humans" (every human driver,
            one shared policy; the robot on its planner) or "both".
        observation: "ego" or "ego+belief" (the robot also observes its social belief; needs a
            learning robot).
        control: "accel" (a learner sets its acceleration and steers along its route by pure
            pursuit, as the built-in planners do) or "accel+steer" (both).
        max_cycles: steps before truncation.
        reward_scale: factor on every reward.
        variants: pedestrian variants drawn uniformly per episode (() : the scenario's own).
        randomize: a randomization preset of evaluation/run.py RANDOMIZATIONS drawn per
            episode ("" : none).
        overrides: scenario parameters for every episode (under the randomization).
    """

    scenario: str = "occluded_crosswalk"
    learn: str = "robot"
    observation: str = "ego"
    control: str = "accel"
    max_cycles: int = 200
    reward_scale: float = 1e-3
    variants: tuple = ()
    randomize: str = ""
    overrides: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.learn not in LEARNERS:
            raise ValueError(f"learn must be one of {LEARNERS}, got {self.learn!r}")
        if self.observation not in OBSERVATIONS:
            raise ValueError(f"observation must be one of {OBSERVATIONS}, got "
                             f"{self.observation!r}")
        if self.control not in CONTROLS:
            raise ValueError(f"control must be one of {CONTROLS}, got {self.control!r}")
        if self.observation == "ego+belief" and self.learn == "humans":
            raise ValueError("observation='ego+belief' is the learning robot's: use --learn "
                             "robot or both")

    @classmethod
    def from_config(cls, config) -> SceneSettings:
        """From RLlib's env_config (a dict of these fields, or a SceneSettings)."""
        if isinstance(config, cls):
            return config
        values = dict(config)
        values["variants"] = tuple(values.get("variants", ()))
        return cls(**values)

    def as_config(self) -> dict:
        return {**asdict(self), "variants": list(self.variants)}


def policy_of(agent: str) -> str:
    """The policy id that acts for an agent (humans share one)."""
    return ROBOT_POLICY if agent.startswith("robot") else HUMAN_POLICY


class ObservationScaler:
    """An observation Box mapped to [-1, 1] per entry: 2 (x - low) / (high - low) - 1, clipped.

    Args:
        space: the agent's observation Box (finite bounds).
    """

    def __init__(self, space: spaces.Box):
        low, high = space.low.astype(np.float64), space.high.astype(np.float64)
        self.middle = 0.5 * (low + high)
        self.half_range = np.maximum(0.5 * (high - low), 1e-6)
        self.space = spaces.Box(-1.0, 1.0, shape=space.shape, dtype=np.float32)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """(size,) float32 in [-1, 1]."""
        return np.clip((obs - self.middle) / self.half_range, -1.0, 1.0).astype(np.float32)


def learner_names(base_env, learn: str) -> list[str]:
    """The agents that learn in a SocialDrivingEnv, in `possible_agents` order."""
    roles = {"robot": ("robot",), "humans": ("human",), "both": ("robot", "human")}[learn]
    return [a for a in base_env.possible_agents if base_env.agent_specs[a].role in roles]


def build_parallel(settings: SceneSettings, overrides: dict):
    """The ParallelEnv of the learners: autopilot (and the belief observation) over the scene.

    Args:
        settings: the scene's settings.
        overrides: this episode's scenario parameters.
    """
    base = parallel_env(scenario=settings.scenario, max_cycles=settings.max_cycles, **overrides)
    learners = learner_names(base, settings.learn)
    if not learners:
        raise ValueError(f"scenario {settings.scenario!r} has no agent to learn for "
                         f"learn={settings.learn!r} (agents: {base.possible_agents})")
    env = autopilot(base, learners)
    if settings.observation == "ego+belief":
        env = BeliefObservationEnv(env, ROBOT)
    return env




def episode_overrides(settings: SceneSettings, episode_seed: int) -> dict:
    """One episode's scenario parameters: the fixed ones, its randomization and variant.

    Args:
        settings: the scene's settings.
        episode_seed: the episode's seed (draws the randomization; picks the variant).
    """
    overrides = dict(settings.overrides)
    if settings.randomize:
        overrides.update(randomized_overrides(episode_seed, settings.randomize))
    if settings.variants:
        overrides["pedestrian"] = settings.variants[episode_seed % len(settings.variants)]
    return overrides


def template_env(settings: SceneSettings):
    """The learners' ParallelEnv of episode seed 0: the one the spaces are declared from."""
    return build_parallel(settings, episode_overrides(settings, 0))


def observation_scalers(env) -> dict[str, ObservationScaler]:
    """{learner: its ObservationScaler} of a learners' ParallelEnv (`template_env`)."""
    return {a: ObservationScaler(env.observation_space(a)) for a in env.possible_agents}


class Actuator:
    """A learner's normalized action in its own units: Box(-1, 1) -> [a m/s^2, delta rad].

    Each entry maps keeping 0 at 0 (envs/homogeneous.py `from_normalized`). With control
    "accel" the action is (1,), the acceleration, and the steering angle is the built-in
    planners' pure pursuit along the agent's own route from the pose in its own observation.

    Args:
        spec: the agent's AgentSpec (a vehicle).
        layout: the shared observation layout.
        road_map: the static map (only the agent's own route is read).
        control: "accel" or "accel+steer".
    """

    def __init__(self, spec, layout, road_map, control: str):
        veh = spec.vehicle
        self.low = np.array([-veh.brake_max_mps2, -veh.steer_max_rad])
        self.high = np.array([veh.accel_max_mps2, veh.steer_max_rad])
        self.wheelbase_m = veh.wheelbase_m
        self.steer = control == "accel+steer"
        self.layout = layout
        self.route = road_map.for_agent(spec.name).routes[spec.name]
        self.space = spaces.Box(-1.0, 1.0, shape=(2 if self.steer else 1,), dtype=np.float32)

    def __call__(self, obs: np.ndarray, action) -> np.ndarray:
        """(2,) float64 env action for the agent's normalized `action` (clipped to [-1, 1]).

        Args:
            obs: the agent's own observation the action answers (its first layout.size
                entries are the shared layout).
            action: (1,) or (2,) normalized action.
        """
        a = np.clip(np.asarray(action, np.float64).reshape(-1), -1.0, 1.0)
        if self.steer:
            return from_normalized(a, self.low, self.high)
        accel = from_normalized(np.array([a[0], 0.0]), self.low, self.high)[0]
        x, y, c, s_, v = (float(e) for e in self.layout.decode(obs[:self.layout.size]).ego[:5])
        s0, _ = self.route.project_point(x, y)
        steer = pure_pursuit(self.route, x, y, math.atan2(s_, c), v, s0, self.wheelbase_m)
        return np.array([accel, steer])


def actuators(env, control: str) -> dict[str, Actuator]:
    """{learner: its Actuator} of a learners' ParallelEnv."""
    base = env.unwrapped
    return {a: Actuator(base.agent_specs[a], base.obs_layout, base.road_map, control)
            for a in env.possible_agents}
