"""The policy protocol every built-in planner follows, and the Boltzmann-policy base.

A policy is built from its agent's spec, the shared observation layout and the static map (the
robot's also from the env's agent names); it never receives the env or the world:

    policy.reset(seed)            # a new episode; seeds its own random stream
    action = policy(obs)          # (obs_dim,) float32 -> (2,) float32

Only a planner with `needs_truth` (the oracle) is also handed the true current state, through
`observe_truth(tracks)`, before each call. A planner that keeps a belief over hidden
pedestrians exposes it as `belief` (a perception.belief.PedestrianBelief).

`BoltzmannPolicy` is the shared pipeline of the human drivers and pedestrians (paper eq. 8):
decode the observation -> update the own tracks -> predict the scene -> Q values -> sample, with
one hook per step that differs.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from marl_social.models.boltzmann import boltzmann
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.perception.tracking import Tracker, TrackSet
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.observation import Measurements, ObservationLayout
from marl_social.sim.road_map import RoadMap


@runtime_checkable
class Policy(Protocol):
    """What the env's users and the evaluation code call on a built-in planner.

    Attributes:
        needs_truth: True only for a planner given the true state of every agent (the
            oracle): its caller must call `observe_truth(tracks)` before every `__call__`.
    """

    needs_truth: bool

    def reset(self, seed: int | None = None) -> None:
        """Start a new episode; `seed` seeds the policy's own random stream."""

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The action (2,) float32 for the agent's own observation (obs_dim,)."""


class BoltzmannPolicy:
    """A noisily-optimal planner: Boltzmann choice over Q values from its own tracks.

    Subclasses set `model` (with `plan_times_s` and `beta`) and implement the hooks
    `q_values` (the Q of each first action), `act` (the chosen index -> an action) and, where
    they differ, `predict` (tracks -> scene), `choose` (the seeded sample) and
    `reset_state` (per-episode state).

    Args:
        spec: the agent's own AgentSpec (its name selects its route).
        layout: the shared observation layout.
        road_map: the static map.
        model: the decision model (DriverModel or PedestrianModel).
    """

    needs_truth = False

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap, model):
        self.name = spec.name
        self.layout = layout
        self.route = road_map.routes[spec.name]
        self.crosswalks = road_map.crosswalks
        self.model = model
        self.tracker = Tracker(spec.sensor.pos_noise_m, spec.sensor.vel_noise_mps)
        self._times = model.plan_times_s

    def reset(self, seed: int | None = None) -> None:
        """Start a new episode: a new random stream from `seed`, empty tracks."""
        self.rng = np.random.default_rng(seed)
        self.tracker.reset()
        self.last_probabilities = None
        self.last_q = None
        self.reset_state()

    def reset_state(self) -> None:
        """Hook: reset the subclass's per-episode state (nothing by default)."""

    def action_distribution(self, obs: np.ndarray) -> np.ndarray:
        """(A,) probabilities of the first actions for this observation (updates the tracks)."""
        decoded = self.layout.decode(obs)
        tracks = self.tracker.update(decoded)
        scene = self.predict(tracks)
        q = self.q_values(decoded, scene)
        self.last_q = q
        self.last_probabilities = boltzmann(q, self.model.beta)
        return self.last_probabilities

    def predict(self, tracks: TrackSet) -> ScenePrediction:
        """Hook: the others' predicted motion from the own tracks (constant velocity)."""
        return ScenePrediction.from_tracks(tracks, self._times)

    def q_values(self, decoded: Measurements, scene: ScenePrediction) -> np.ndarray:
        """Hook: (A,) Q values of the first actions from the own state and the scene."""
        raise NotImplementedError

    def choose(self, probabilities: np.ndarray) -> int:
        """Hook: an action index sampled from (A,) `probabilities` with `self.rng`."""
        raise NotImplementedError

    def act(self, chosen: int, obs: np.ndarray) -> np.ndarray:
        """Hook: the (2,) float32 action of first action `chosen` for observation `obs`."""
        raise NotImplementedError

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The sampled action (2,) float32 for the agent's own observation (obs_dim,)."""
        probabilities = self.action_distribution(obs)
        return self.act(self.choose(probabilities), obs)
