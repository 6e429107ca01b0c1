"""The robot's social belief as part of its observation (`observation="ego+belief"`).

    env = marl_social.parallel_env(scenario="occluded_crosswalk", observation="ego+belief")
    env = belief_observation(marl_social.autopilot(base_env, ["robot_0"]))  # the same, robot only

The robot's observation (the shared layout, marl_social/sim/observation.py) gets L + 1 more
float32 entries, computed from its own observations by the social planner's belief (the
`PedestrianBelief` the "social" robot planner builds and updates, perception/belief/):

* [size, size + L): each hypothesis' posterior probability, in `belief.hypotheses` order
  ("none" first; on the occluded crosswalk L = 13), in [0, 1];
* [size + L]: the arrival time of the nearest possible hidden agent in the robot's lane [s], in
  [0, ARRIVAL_HORIZON_S]: the earliest time at which a hypothesis the belief keeps
  (`belief.live()`, probability >= epsilon) puts its hidden agent on the robot's route, within
  half a lane plus half the agent's width, where the robot has not yet passed;
  ARRIVAL_HORIZON_S when none does within the horizon.

Every other agent's observation is unchanged. The wrapper goes outside `autopilot` (a built-in
robot planner reads only the shared layout). Opt-in: the default `observation="ego"` builds no
belief, and the seeded episodes are unchanged.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from marl_social.envs.policies import make_policy

ARRIVAL_HORIZON_S = 8.0  # the arrival times looked at [s]; also "no hidden agent coming"
ARRIVAL_STEP_S = 0.1  # the arrival time's resolution [s]
OBSERVATIONS = ("ego", "ego+belief")  # parallel_env's `observation` options


class BeliefFeatures:
    """The belief part of the robot's observation, from its own observations only.

    Args:
        spec: the robot's AgentSpec.
        layout: the shared observation layout.
        road_map: the static map (the belief and the route see only the robot's own view,
            `RoadMap.for_agent`).
        agent_names: the env's possible_agents (as for `make_policy`).
    """

    def __init__(self, spec, layout, road_map, agent_names):
        self.layout = layout
        # the social planner's own belief object, built as that planner builds it
        self.belief = make_policy(spec, layout, road_map, agent_names, "social").belief
        own_map = road_map.for_agent(spec.name)
        self.route = own_map.routes[spec.name]
        self._lane_half_width_m = 0.5 * min((lane.width_m for lane in own_map.lanes),
                                            default=3.5)
        self._arrivals_of = None
        self.n_hypotheses = len(self.belief.hypotheses)
        self.size = self.n_hypotheses + 1

    def extend(self, space: spaces.Box) -> spaces.Box:
        """The robot's observation Box with the features' bounds appended."""
        return spaces.Box(
            low=np.concatenate([space.low, np.zeros(self.size, np.float32)]),
            high=np.concatenate([space.high, np.ones(self.n_hypotheses, np.float32),
                                 np.float32([ARRIVAL_HORIZON_S])]),
            dtype=np.float32)

    def reset(self) -> None:
        """Back to the prior (every episode start)."""
        self.belief.reset()

    def __call__(self, robot_obs: np.ndarray) -> np.ndarray:
        """(L + 1,) float32: the belief after folding in `robot_obs`, and the arrival time [s].

        Call once per step, in order (the belief is a filter).

        Args:
            robot_obs: (layout.size,) the robot's own observation of this step.
        """
        belief = self.belief
        if len(belief.hypotheses) != self.n_hypotheses:
            raise RuntimeError(f"the belief's hypotheses changed from {self.n_hypotheses} to "
                               f"{len(belief.hypotheses)}: the observation space no longer fits")
        probabilities = belief.update(robot_obs)
        x, y = (float(v) for v in self.layout.decode(robot_obs).ego[:2])
        s_robot, _ = self.route.project_point(x, y)
        arrival_s, arrival_at_m = self._arrivals()
        present = np.array([h.present for h in belief.hypotheses])
        coming = belief.live() & present & (arrival_at_m >= s_robot)
        nearest = float(arrival_s[coming].min()) if coming.any() else ARRIVAL_HORIZON_S
        return np.concatenate([probabilities, [nearest]]).astype(np.float32)

    def _arrivals(self) -> tuple[np.ndarray, np.ndarray]:
        """(L,) each hypothesis' arrival time in the robot's lane [s] and where on its route [m].

        From the belief's own prediction of each hypothesis' hidden agent
        (`belief.hypothesis_objects`); ARRIVAL_HORIZON_S and -inf where it does not arrive
        within the horizon. Computed once per hypothesis list.
        """
        if self._arrivals_of is not None and self._arrivals_of[0] is self.belief.hypotheses:
            return self._arrivals_of[1]
        times = np.arange(0.0, ARRIVAL_HORIZON_S + 1e-9, ARRIVAL_STEP_S)
        xy, _, _, width, _, present = self.belief.hypothesis_objects(times)
        s, lateral, _ = self.route.project(xy)  # (L, T) each
        in_lane = np.abs(lateral) <= self._lane_half_width_m + 0.5 * width[:, None]
        in_lane &= present[:, None]
        first = np.argmax(in_lane, axis=1)
        arrives = in_lane.any(axis=1)
        rows = np.arange(len(first))
        arrival_s = np.where(arrives, times[first], ARRIVAL_HORIZON_S)
        arrival_at_m = np.where(arrives, s[rows, first], -np.inf)
        self._arrivals_of = (self.belief.hypotheses, (arrival_s, arrival_at_m))
        return arrival_s, arrival_at_m



class BeliefObservationEnv:
    """A ParallelEnv whose robot observes its social belief too (see the module docstring).

    Args:
        env: a SocialDrivingEnv or a parallel wrapper of one (e.g. `autopilot`) that exposes
            the robot.
        robot: the robot's agent name.
    """

    def __init__(self, env, robot: str = "robot_0"):
        self.env = env
        base = self.unwrapped
        if robot not in env.possible_agents or base.agent_specs[robot].role != "robot":
            raise ValueError(f"observation='ego+belief': {robot!r} is not a robot the env "
                             f"exposes (agents: {env.possible_agents})")
        self.robot = robot
        self.possible_agents = list(env.possible_agents)
        self.metadata = env.metadata
        self.render_mode = getattr(env, "render_mode", None)
        self.features = BeliefFeatures(base.agent_specs[robot], base.obs_layout, base.road_map,
                                       base.possible_agents)
        self.robot_space = self.features.extend(env.observation_space(robot))
        self.agents: list[str] = []

    @property
    def unwrapped(self):
        """The SocialDrivingEnv underneath."""
        return self.env.unwrapped if hasattr(self.env, "unwrapped") else self.env

    @property
    def state_space(self):
        return self.env.state_space

    def observation_space(self, agent: str) -> spaces.Box:
        """The robot's extended Box; every other agent's from the wrapped env."""
        return self.robot_space if agent == self.robot else self.env.observation_space(agent)

    def action_space(self, agent: str) -> spaces.Box:
        return self.env.action_space(agent)

    def reset(self, seed: int | None = None, options: dict | None = None):
        """Reset the env and the belief (to its prior); the robot's first observation folded in."""
        obs, infos = self.env.reset(seed=seed, options=options)
        self.features.reset()
        self.agents = list(self.env.agents)
        return self._extend(obs), infos

    def step(self, actions: dict):
        obs, rewards, terminations, truncations, infos = self.env.step(actions)
        self.agents = list(self.env.agents)
        return self._extend(obs), rewards, terminations, truncations, infos

    def render(self):
        return self.env.render()

    def close(self):
        self.env.close()

    def state(self) -> np.ndarray:
        return self.env.state()

    def _extend(self, obs: dict) -> dict:
        if self.robot not in obs:
            return obs
        out = dict(obs)
        out[self.robot] = np.concatenate([obs[self.robot], self.features(obs[self.robot])])
        return out


def belief_observation(env, robot: str = "robot_0") -> BeliefObservationEnv:
    """Wrap a parallel env so that the robot also observes its social belief (see the module)."""
    return BeliefObservationEnv(env, robot)
