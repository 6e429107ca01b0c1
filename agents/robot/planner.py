"""The robot's planners: the same contingency MPC (agents/robot/mpc.py), different beliefs.

* ``social`` (the paper): beliefs over hidden pedestrians from the robot's own sensors
  (negative information) and from the humans' behaviour (eq. 9-10), perception/belief/.
* ``social+beta`` (beyond the paper): ``social`` that also infers each human's rationality
  beta on a grid (BeliefConfig.beta_grid_hat; confidence-aware prediction, Fridovich-Keil et
  al. 2019), so an erratic human's behaviour moves the belief less.
* ``aggressive``: what is not seen is absent (no hidden-pedestrian hypotheses).
* ``conservative``: every hidden-pedestrian hypothesis its own sensors have not ruled out is
  assumed true (no social inference).
* ``oracle``: perfect perception, an upper bound: it is the one planner given the true current
  state of every agent (``needs_truth``; through ``observe_truth``, called by `run_episode`
  and the autopilot), with no hidden hypotheses. It knows where everybody is, not what they
  will decide.

Every planner's scenes are its tracked objects (the oracle: the truth) in every branch plus,
per hypothesis, that hypothesis' hidden agent (a pedestrian, or a car on its lane; the belief's
`hypothesis_objects`). A tracked car in a lane is predicted along its lane path at its speed
along it, the rest at constant velocity (agents/robot/track_prediction.py). At conflict zones
where the robot yields, a car with the right of way predicted there claims the zone in its
branch (agents/robot/right_of_way.py): the robot waits or clears the zone well before the car
arrives. So the oracle gives way to the hidden car it knows of from the start, the
conservative planner to every hidden car it cannot rule out, the aggressive one only to a car
it sees, and the social one to those its belief holds. With the
planner parameter "sight_hold" (off by default) a belief-based planner pulling out of a stop
sign also holds short of the lane it cannot see while a human that will tell is still coming
(agents/robot/sight_hold.py).

All but the oracle act on the robot's own observation and the static map only. Each planner is
one `RobotVariant` (data, in `ROBOT_VARIANTS`); agents/registry.py registers them by name.

A decision is a pipeline (agents/robot/pipeline.py): the observation becomes a planning record,
which the robot's stages (agents/robot/stages.py, chosen from the map elements along its route)
refine in turn, and the contingency MPC plans over it. The robot is built from one
`RobotSettings` record (agents/robot/settings.py): its variant, its model of the humans (its own
spec's planner parameters, the robot's private knowledge: "theta_hat", "beta_hat", "epsilon",
agents/params.RobotModelParams) and each stage's configuration.

Where the map has a signal plan every planner obeys its own head as it reads
it (agents/robot/signal_stop.py: right turn on red after stopping) and keeps a belief over the
signal phase (perception/belief/phase.py; from its own head, and for ``social`` also from the
humans' behaviour). The MPC's branches then split by what the signalled traffic does
(agents/robot/phase_branches.py): ``social`` weighs "stops at its line" against "drives on" by
its phase belief, ``oracle`` by the true phase (``observe_truth``'s signal_phase),
``aggressive`` assumes the favourable phase (every signalled car stops at its line) and
``conservative`` that none does (it waits for the cross traffic to stop or pass).
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.agents.robot.corridor import static_outlines
from marl_social.agents.robot.mpc import ContingencyMpc
from marl_social.agents.robot.mpc_types import MpcResult, PlanRequest
from marl_social.agents.robot.pipeline import PlanningRecord, Stage, Truth
from marl_social.agents.robot.settings import RobotSettings, resolve_settings
from marl_social.agents.robot.stages import (
    BeliefUpdate,
    RobotContext,
    SignalBranches,
    build_stages,
)
from marl_social.models.steering import pure_pursuit
from marl_social.perception.belief import PedestrianBelief
from marl_social.perception.tracking import TrackSet
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.observation import ObservationLayout
from marl_social.sim.road_map import RoadMap

# the MPC's QP layouts of up to this many live branches are built with the planner, not at the
# first plan that meets them (ContingencyMpc.build_layouts; once per process): the three
# built-in scenes' episodes meet at most 9
PREBUILT_BRANCHES = 10


class RobotPlanner:
    """Contingency-MPC robot: a pipeline of stages, then the MPC (see module docstring).

    Args:
        spec: the robot's AgentSpec.
        layout: the shared observation layout.
        road_map: the static map.
        agent_names: the env's possible_agents (public: maps object ids to names / routes).
        settings: the planner variant, the robot's model of the humans and each stage's
            configuration (default: RobotSettings(), the social planner, its model parsed
            from spec.planner).

    Raises:
        ValueError: an unknown planner, or a planner parameter unknown or out of range.
    """

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap,
                 agent_names: list[str], settings: RobotSettings | None = None):
        self.settings = resolve_settings(spec, settings or RobotSettings())
        self.variant = self.settings.variant
        self.needs_truth = self.variant.needs_truth
        self.name, self.spec, self.layout = spec.name, spec, layout
        self.road_map = road_map  # the robot's own view of the map: its route only
        self.route = road_map.routes[spec.name]
        self.mpc = self.settings.mpc
        self.solver = ContingencyMpc(self.mpc, spec.vehicle)
        self.solver.build_layouts(PREBUILT_BRANCHES)
        # the belief keeps the robot's Kalman tracks of what it sees; the MPC reads the same ones
        self.belief = PedestrianBelief(
            road_map, layout, spec.name, list(agent_names), self.settings.belief,
            use_social=self.variant.use_social,
            use_own_sensors=self.variant.use_own_sensors,
        )
        self.stages: tuple[Stage, ...] = build_stages(RobotContext(
            spec, self.route, road_map, self.mpc, self.belief, self.settings))
        signals = self.stage(SignalBranches)
        # the belief over the signal phase (None: no signal plan), recorded by run_episode
        self.phase_belief = signals.phase_belief if signals is not None else None
        self._static_outlines = static_outlines(road_map.static_polygons)
        self._truth: Truth | None = None
        self.reset()

    def stage(self, kind: type) -> Stage | None:
        """The robot's stage of type `kind` (None: its route has no element that calls for it)."""
        return next((s for s in self.stages if isinstance(s, kind)), None)

    def reset(self, seed: int | None = None) -> None:
        """Start a new episode: every stage's state (belief, lines, curbs), fresh QPs.

        Args:
            seed: unused (the robot's decisions are deterministic).
        """
        for stage in self.stages:
            stage.reset()
        self.solver.reset()
        self.prev_accel = 0.0
        self.last_result: MpcResult | None = None
        self.last_record: PlanningRecord | None = None

    def observe_truth(self, tracks: TrackSet, signal_phase: int | None = None) -> None:
        """Give the planner the true current state of every other agent (oracle only).

        Args:
            tracks: the true state of every other active agent (envs/policies.truth_tracks).
            signal_phase: the signal plan's running phase (envs/policies.truth_signal_phase;
                None: no signals).

        Raises:
            RuntimeError: the planner does not have `needs_truth`.
        """
        if not self.needs_truth:
            raise RuntimeError(f"robot {self.name}: only a planner with needs_truth (the oracle) "
                               "may read the true state")
        self._truth = Truth(tracks, signal_phase)

    def v_ref(self) -> float:
        """The speed the MPC tracks [m/s] (stages.BeliefUpdate.v_ref)."""
        return self.stage(BeliefUpdate).v_ref()

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The (2,) [acceleration m/s^2, steering rad] for the robot's observation (obs_dim,)."""
        decoded = self.layout.decode(obs)
        x, y, c, s_, v = (float(a) for a in decoded.ego[:5])
        s0, _ = self.route.project_point(x, y)
        record = PlanningRecord(obs, decoded, s0, v, truth=self._truth)
        for stage in self.stages:
            record = stage(record)
        self.last_record = record
        result = self.solver.plan(self.route, PlanRequest(
            s0, v, self.prev_accel, record.v_ref_mps, self.road_map.speed_limit_mps,
            record.scene, record.weights, self._static_outlines, record.stop_at_m,
            record.contingent, record.claims, record.pull_up_to_m))
        self.last_result = result
        self.prev_accel = result.accel_mps2
        steer = pure_pursuit(self.route, x, y, math.atan2(s_, c), v, s0,
                             self.spec.vehicle.wheelbase_m)
        return np.array([result.accel_mps2, steer], dtype=np.float32)
