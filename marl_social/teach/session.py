"""One episode stepped on demand, each step as a JSON frame (scene_json.py).

The episode is the one `marl_social.evaluation.run_episode` runs for the same scenario,
settings and seed: the env reset with the seed, each agent's policy with seed + its index, the
oracle fed its truth before each decision. What the page shows of the robot is read from what
its policy exposes (`belief`, `last_result`, `mpc`): nothing here changes it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from marl_social.envs.parallel import parallel_env
from marl_social.envs.policies import policies, truth_signal_phase, truth_tracks
from marl_social.sim.dynamics import DT_S
from marl_social.sim.seeds import checked_seed
from marl_social.teach import scene_json

ROBOT = "robot_0"
DEFAULT_MAX_CYCLES = 200  # steps per episode, as `marl-social demo`


@dataclass(frozen=True)
class EpisodeConfig:
    """What an episode is built from.

    Attributes:
        scenario: a registered scenario name.
        settings: {settings-tree leaf: value}, validated (controls.validate_settings).
        seed: the episode's seed.
        max_cycles: the step limit.
    """

    scenario: str = "occluded_crosswalk"
    settings: dict = field(default_factory=dict)
    seed: int = 0
    max_cycles: int = DEFAULT_MAX_CYCLES


class EpisodeSession:
    """An env and its built-in policies, reset from a config and stepped one step at a time.

    Args:
        config: the scenario, settings and seed.
    """

    def __init__(self, config: EpisodeConfig):
        self.config = config
        self.env = parallel_env(scenario=config.scenario, max_cycles=config.max_cycles,
                                **config.settings)
        self.policies = policies(self.env)
        robot = self.policies.get(ROBOT)
        self.robot = robot
        self.belief = getattr(robot, "belief", None)
        # the oracle's belief is not its input (it plans on the truth): not shown
        if robot is not None and getattr(robot, "needs_truth", False):
            self.belief = None
        mpc = getattr(robot, "mpc", None)
        self.plan_dt_s = float(mpc.plan_dt_s) if mpc is not None else None
        self.reset()

    def reset(self) -> dict:
        """Back to the episode's start; returns its first frame."""
        seed = checked_seed(self.config.seed)
        names = self.env.possible_agents
        for name, policy in self.policies.items():
            policy.reset(seed + names.index(name))
        self.obs, _ = self.env.reset(seed=seed)
        self.steps = 0
        self.last_plan = None
        return self.frame()

    @property
    def done(self) -> bool:
        """Every agent has left the episode (arrived, collided or truncated)."""
        return not self.env.agents

    def header(self) -> dict:
        """What stays fixed over the episode: map, agents, colours, time steps [s]."""
        world = self.env.world
        return {
            "scenario": self.config.scenario, "seed": self.config.seed,
            "planner": self.env.scenario.params.robot_planner,
            "dt": DT_S, "plan_dt": self.plan_dt_s, "max_steps": self.config.max_cycles,
            "map": scene_json.map_json(world.road_map, ROBOT if ROBOT in world.names else None),
            "agents": scene_json.agents_json(self.env),
            "robot": world.names.index(ROBOT) if ROBOT in world.names else None,
            "palette": scene_json.palette(),
        }

    def _act(self, name: str):
        policy = self.policies[name]
        if name == ROBOT and getattr(policy, "needs_truth", False):
            policy.observe_truth(truth_tracks(self.env, name),
                                 signal_phase=truth_signal_phase(self.env))
        action = policy(self.obs[name])
        if name == ROBOT:
            self.last_plan = getattr(policy, "last_result", None)
        return action

    def step(self) -> dict:
        """One env step with every live agent's policy; returns the new frame."""
        if self.done:
            return self.frame()
        actions = {name: self._act(name) for name in self.env.agents}
        self.obs, *_ = self.env.step(actions)
        self.steps += 1
        return self.frame()

    def frame(self) -> dict:
        """The current step: agents, fields of view, what the robot sees, belief, plan."""
        world = self.env.world
        state = world.state
        robot = world.names.index(ROBOT) if ROBOT in world.names else None
        frame = {
            "step": self.steps, "t": round(float(world.time_s), 3), "done": self.done,
            "agents": [[round(float(s[0]), 2), round(float(s[1]), 2), round(float(s[2]), 3),
                        round(float(s[3]), 2), int(a)] for s, a in zip(state, world.active)],
            "fov": scene_json.fov_outlines(world, self.env.last_fov),
            "seen": ([int(j) for j in self.env.last_fov.visible[robot].nonzero()[0]]
                     if robot is not None else []),
            "signals": [int(k) for k in world.signal_states()],
            "belief": None, "plan": None,
        }
        if self.belief is not None:
            frame["belief"] = scene_json.belief_json(self.belief)
        if self.last_plan is not None and self.plan_dt_s is not None:
            labels = [h.name for h in self.belief.hypotheses] if self.belief is not None else []
            frame["plan"] = scene_json.plan_json(self.last_plan, self.plan_dt_s, labels)
        return frame

    def close(self) -> None:
        """Free the env."""
        self.env.close()
