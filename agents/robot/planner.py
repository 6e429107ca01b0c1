"""The robot's planners: the same contingency MPC (agents/mpc.py), different beliefs.

* ``social`` (the paper): beliefs over hidden pedestrians from the robot's own sensors
  (negative information) and from the humans' behaviour (eq. 9-10), perception/belief.py.
* ``social+beta`` (beyond the paper): ``social`` that also infers each human's rationality
  beta on a grid (BeliefConfig.beta_grid_hat; confidence-aware prediction, Fridovich-Keil et
  al. 2019), so an erratic human's behaviour moves the belief less.
* ``aggressive``: what is not seen is absent (no hidden-pedestrian hypotheses).
* ``conservative``: every hidden-pedestrian hypothesis its own sensors have not ruled out is
  assumed true (no social inference).
* ``oracle``: perfect perception, an upper bound: it is the one planner given the true current
  state of every agent (through ``observe_truth``, called by `run_episode`), with no hidden
  hypotheses. It knows where everybody is, not what they will decide.

All but the oracle act on the robot's own observation and the static map only.

The robot's model of the humans and its tail threshold come from its own spec's planner
parameters (the robot's private knowledge; scenario knobs robot_theta_hat, robot_beta_hat,
robot_epsilon): "theta_hat" (cost weights, e.g. learned by agents/irl.py), "beta_hat",
"epsilon".
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from marl_social.agents.robot.mpc import MpcConfig, MpcResult, plan
from marl_social.perception.belief import BeliefConfig, PedestrianBelief
from marl_social.perception.tracking import TrackSet

from marl_social.models.candidates import ScenePrediction
from marl_social.models.steering import pure_pursuit
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.costs import CostWeights
from marl_social.sim.observation import ObservationLayout
from marl_social.sim.road_map import RoadMap

ROBOT_PLANNERS = ("social", "social+beta", "aggressive", "conservative", "oracle")
BETA_GRID_HAT = (0.03, 0.1, 0.3, 1.0, 3.0)  # social+beta: rationality grid (log-spaced)


def robot_configs(spec: AgentSpec, mode: str) -> tuple[MpcConfig, BeliefConfig]:
    """The MPC and belief configuration of a robot from its spec (see module docstring)."""
    params = spec.planner
    unknown = sorted(set(params) - {"theta_hat", "beta_hat", "epsilon"})
    if unknown:
        raise ValueError(f"robot {spec.name}: unknown planner parameter(s) {unknown}; known: "
                         "theta_hat, beta_hat, epsilon")
    belief = BeliefConfig()
    updates = {}
    if "theta_hat" in params:
        updates["theta_hat"] = CostWeights.from_any(params["theta_hat"])
    if "beta_hat" in params:
        beta_hat = float(params["beta_hat"])
        if not beta_hat >= 0:
            raise ValueError(f"robot {spec.name}: beta_hat must be >= 0, got {beta_hat}")
        updates["beta_hat"] = beta_hat
    epsilon = float(params.get("epsilon", belief.epsilon))
    if not 0.0 <= epsilon < 1.0:
        raise ValueError(f"robot {spec.name}: epsilon must be in [0, 1), got {epsilon}")
    updates["epsilon"] = epsilon
    if mode == "social+beta":
        updates["beta_grid_hat"] = BETA_GRID_HAT
    return (MpcConfig(theta=spec.cost_weights, epsilon=epsilon),
            replace(belief, **updates))


class RobotPlanner:
    """Contingency-MPC robot (see module docstring).

    Args:
        spec: the robot's AgentSpec; layout: observation layout; road_map: static map;
        agent_names: the env's possible_agents (public: maps object ids to names / routes);
        mode: one of ROBOT_PLANNERS.
    """

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap,
                 agent_names: list[str], mode: str = "social",
                 mpc_config: MpcConfig | None = None, belief_config: BeliefConfig | None = None):
        if mode not in ROBOT_PLANNERS:
            raise ValueError(f"robot planner {mode!r}: must be one of {ROBOT_PLANNERS}")
        self.name = spec.name
        self.mode = mode
        self.spec = spec
        self.layout = layout
        self.road_map = road_map
        self.route = road_map.routes[spec.name]
        default_mpc, default_belief = robot_configs(spec, mode)
        self.mpc = mpc_config or default_mpc
        self.v_ref = min(spec.v_desired_mps, road_map.speed_limit_mps)
        # the belief keeps the robot's Kalman tracks of what it sees; the MPC reads the same ones
        self.belief = PedestrianBelief(
            road_map, layout, spec.name, list(agent_names), belief_config or default_belief,
            use_social=mode in ("social", "social+beta"),
            use_own_sensors=mode in ("social", "social+beta", "conservative"),
        )
        self._times = self.mpc.candidates.plan_times_s
        self._truth: TrackSet | None = None
        self._static_boxes = np.array(
            [[*p.min(axis=0), *p.max(axis=0)] for p in road_map.static_polygons]).reshape(-1, 4)
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self.belief.reset()
        self.prev_accel = 0.0
        self.last_result: MpcResult | None = None
        self.weights = None

    def observe_truth(self, tracks: TrackSet) -> None:
        """Oracle only: the true current state of every other agent, as a TrackSet."""
        if self.mode != "oracle":
            raise RuntimeError(f"only the oracle planner may read the true state (mode={self.mode})")
        self._truth = tracks

    def hypothesis_weights(self) -> np.ndarray:
        """(L,) the weights the MPC plans with: the belief for `social`, every live present
        hypothesis for `conservative`, only "none" for `aggressive` and `oracle`.
        """
        hyps = self.belief.hypotheses
        none = np.array([not h.present for h in hyps])
        if self.mode in ("aggressive", "oracle"):
            return none.astype(np.float64)
        b = self.belief.probabilities
        if self.mode in ("social", "social+beta"):
            return b
        present_live = ~none & (b >= self.mpc.epsilon)
        if not present_live.any():
            return none.astype(np.float64)
        return present_live / present_live.sum()

    def __call__(self, obs) -> np.ndarray:
        decoded = self.layout.decode(obs)
        x, y, c, s_, v = (float(a) for a in decoded.ego[:5])
        psi = math.atan2(s_, c)
        if self.mode == "oracle":
            if self._truth is None:
                raise RuntimeError("oracle planner: observe_truth() must be called every step")
            tracks = self._truth
        else:
            self.belief.update(obs)  # own tracks (+ negative / social information by mode)
            tracks = self.belief.tracker.tracks()
        weights = self.hypothesis_weights()
        self.weights = weights
        scene = self._scene(tracks)
        s0, _ = self.route.project_point(x, y)
        result = plan(self.mpc, self.spec.vehicle, self.route, s0, v, self.prev_accel, self.v_ref,
                      self.road_map.speed_limit_mps, scene, weights, self.road_map.crosswalks,
                      self._static_boxes)
        self.last_result = result
        self.prev_accel = result.accel_mps2
        steer = pure_pursuit(self.route, x, y, psi, v, s0, self.spec.vehicle.wheelbase_m)
        return np.array([result.accel_mps2, steer], dtype=np.float32)

    def _scene(self, tracks: TrackSet) -> ScenePrediction:
        """One scene per hypothesis: the tracked objects plus that hypothesis' pedestrian."""
        base = ScenePrediction.from_tracks(tracks, self._times)
        hyps = self.belief.hypotheses
        n_t = len(self._times)
        xy = np.zeros((len(hyps), n_t, 2))
        heading = np.zeros((len(hyps), n_t))
        for i, h in enumerate(hyps):
            if h.present:
                xy[i] = h.predict_xy(self._times)
                heading[i] = math.atan2(h.walk_dir[1], h.walk_dir[0])
        present = np.array([h.present for h in hyps])
        diameter = np.full(len(hyps), 0.6)
        return base.with_extra(xy, heading, diameter, diameter, np.ones(len(hyps), bool), present)
