"""The robot's prediction of a human driver: Q*_H under every hypothesis and traffic speed.

The first job of social perception (eq. 11): what would a human do under each hidden-agent
hypothesis l and traffic speed v? `HumanPrediction.human_q_values` evaluates the human's
candidate plans once for all L scenes (the hypothesised agent, where the human can see it, and
the objects the robot tracks; human_scene.HumanScenes) without the speed feature, which is then
added for each v: exactly driver_q_values(DriverModel(theta_hat, beta_hat, v_desired_mps=v))
for every (l, v) from a single rollout (tests/perception/belief/test_social.py checks it). The
human keeps the right of way (`yield_zones`) and its path's curve speed (`curve_speed`) like the
simulated drivers (models/driver.RoadRules). Scoring an observed action against these Q-values
is action_scoring.py's job; the coordination per tracked human is social.py's.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from marl_social.models.candidates import PlanningEgo, Surroundings
from marl_social.models.driver import DriverModel, RoadRules, rule_abiding_totals
from marl_social.models.gap_evaluation import vehicle_gap_evaluations
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.models.yield_expectation import YieldExpectation
from marl_social.perception.belief import compiled
from marl_social.perception.belief.action_model import speed_nodes_mps
from marl_social.perception.belief.config import BeliefConfig
from marl_social.perception.belief.human_scene import HumanScenes
from marl_social.perception.belief.hypotheses import Hypothesis
from marl_social.perception.belief.paths import route_pose
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.dynamics import DT_S
from marl_social.sim.road_map import RoadMap, Route
from marl_social.sim.route_rules import CurveSpeed, priority_mask, route_conflicts

# the lateral acceleration the robot assumes a human accepts in a bend (a generic driver's;
# a human slowing for its turn is then not read as giving way to a hidden car) [m/s^2]
HUMAN_CURVE_LAT_ACCEL_MPS2 = 2.5
KEPT_ROWS_MAX = 256  # the kept-hypothesis rows remembered per set of present hypotheses


class HumanPrediction:
    """The robot's model of a human driver's costs: Q*_H per hypothesis and traffic speed.

    Args:
        road_map: the static map (crosswalks, lanes, conflict zones).
        hypotheses: the L hidden-agent hypotheses (pedestrians and vehicles).
        traffic_grid_mps: (V,) traffic speeds of the traffic-speed belief [m/s].
        config: BeliefConfig (theta_hat, beta_hat, the human's assumed view, ...).

    Attributes:
        model: DriverModel(theta_hat, beta_hat), the robot's model of a human (eq. 8, 11).
        scenes: the scenes the human is modelled against (human_scene.HumanScenes).
    """

    def __init__(self, road_map: RoadMap, hypotheses: list[Hypothesis],
                 traffic_grid_mps: np.ndarray, config: BeliefConfig):
        self.road_map = road_map
        self.traffic_grid_mps = traffic_grid_mps
        # the robot's model of a human (eq. 8, 11); the speed feature is added per v_ref
        self.model = DriverModel(theta=config.theta_hat, beta=config.beta_hat,
                                 vehicle=VehicleParams())
        self._candidates = self.model.candidates
        self._theta_no_speed = replace(config.theta_hat, speed=0.0).as_array()
        times = self._candidates.plan_times_s
        first = np.asarray(self._candidates.first_actions_mps2, dtype=np.float64)
        veh = self.model.vehicle  # the first actions within the vehicle's limits (executed)
        self._first_limited = np.clip(first, -veh.brake_max_mps2, veh.accel_max_mps2)
        self.has_vehicles = any(h.kind == "vehicle" for h in hypotheses)
        self._kept_rows_memo: dict[bytes, tuple] = {}  # present (L,) -> (inverse, keep)
        # the speed feature theta_speed (v - v_ref)^2 per planner step, in simulator-step units
        self._speed_weight = config.theta_hat.speed * (self._candidates.plan_dt_s / DT_S)
        self.scenes = HumanScenes(
            hypotheses, times, config, self.model.vehicle,
            YieldExpectation(road_map) if config.human_expects_yield else None)
        self._conflicts: dict[str, tuple] = {}  # route name -> its yield conflicts
        self._curves: dict[str, CurveSpeed | None] = {}  # route name -> its curve speed

    def human_q_values(self, route: Route, s0: float, v0: float, prev_accel: float,
                       others: ScenePrediction | None = None,
                       negligible: np.ndarray | None = None,
                       speed_std_mps: float | None = None) -> np.ndarray:
        """Q*_H(x_l, v, u) for every hidden-agent hypothesis l and traffic speed v, one rollout.

        Equal to driver_q_values(DriverModel(theta_hat, beta_hat, v_desired_mps=v), route, s0,
        v0, prev_accel, scene_l, crosswalks) with scene_l = `others` plus hypothesis l's hidden
        agent (eq. 11; a hypothesised vehicle only if the human at s0 can see it,
        `hypothesis_scene` with the human as viewer): the candidates are evaluated once for
        all L scenes without the speed feature, which is then added for each v.

        Args:
            route: the human's route.
            s0: its arc length along the route [m].
            v0: its along-route speed [m/s].
            prev_accel: its previous acceleration [m/s^2].
            others: one-hypothesis scene of the other objects the human reacts to (None:
                nothing but the hypothesised agent).
            negligible: (L,) bool, hypotheses whose hidden agent is left out of the human's
                scene (their belief is negligible: SocialLikelihood.log_likelihoods);
                None: none is.
            speed_std_mps: the std of the robot's estimate v0 of the human's speed [m/s]: the
                Q-values from each of action_model.speed_nodes_mps(v0, speed_std_mps), the
                scene built once (`speed_averaged_log_likelihood` weighs them). None: from v0.

        Returns:
            (L, V, A) optimal cost-to-go of each first action; (3, L, V, A) with speed_std_mps.
        """
        viewer = None
        if self.has_vehicles:
            x, y, heading = route_pose(route, s0)
            viewer = (np.array([x, y]), heading)
        return self.q_values(route, s0, v0, prev_accel, others, negligible, viewer,
                              speed_std_mps)

    def q_values(self, route: Route, s0: float, v0: float, prev_accel: float,
                  others: ScenePrediction | None, negligible: np.ndarray | None,
                  viewer: tuple | None, speed_std_mps: float | None = None) -> np.ndarray:
        """`human_q_values` with the human's view (xy (2,) [m], heading [rad]) already known.

        viewer None: every hypothesised agent is in its scene (no vehicle hypotheses).
        speed_std_mps: as human_q_values (None: (L, V, A) from v0; else (3, L, V, A)).
        """
        objects = self.scenes.objects_in_view(viewer)
        # every hypothesis whose hidden agent is not in the human's scene ("none", a car out of
        # its view) gives the scene of "none": the candidates are evaluated once for all of them
        present = objects[5]
        if negligible is not None:
            present = present & ~negligible
        inverse, keep = self._kept_rows(present)
        scene = self.scenes.kept_scene(others, objects, keep)  # hypothesis_scene(others, viewer)[keep]
        zones = self.yield_zones(route, s0, scene)
        curve = self.curve_speed(route)
        nodes = ((v0,) if speed_std_mps is None
                 else tuple(speed_nodes_mps(v0, speed_std_mps).tolist()))
        # equal nodes (a human at rest) evaluated once; a signed zero is not its opposite's
        keys = [(v, math.copysign(1.0, v)) for v in nodes]
        distinct = list(dict.fromkeys(keys))
        evaluations = vehicle_gap_evaluations(
            PlanningEgo(self._candidates, self._theta_no_speed, 0.0, self.model.vehicle, route,
                        s0, v0, prev_accel), [v for v, _ in distinct],
            Surroundings(scene, self.road_map.crosswalks, zones, self.model.yield_margin_s,
                         curve))
        # (K, A, C): predicted collisions and plans too fast for its bends excluded
        rules = RoadRules(None, zones, curve)
        totals = {key: (np.ascontiguousarray(rule_abiding_totals(ev, self.model, s0, rules)),
                        np.ascontiguousarray(ev.v))
                  for key, ev in zip(distinct, evaluations, strict=True)}
        if any(not base.shape[-1] for base, _ in totals.values()):
            raise ValueError("HumanPrediction: the model's candidates have no continuations")
        # compiled: the speed feature, its minimum over the continuations (the numpy
        # formulation it replaced: tests/perception/test_belief_kernels.py)
        kernels = compiled.kernels()
        if speed_std_mps is None:
            base, plan_speed = totals[keys[0]]
            return kernels.speed_q_values(base, plan_speed, self.traffic_grid_mps,
                                          self._speed_weight, inverse)
        bases, plan_speeds = zip(*(totals[key] for key in keys), strict=True)
        return kernels.node_speed_q_values(bases, plan_speeds, self.traffic_grid_mps,
                                           self._speed_weight, inverse)

    def _kept_rows(self, present: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(L,) row of each hypothesis in the kept scenes and the (K,) kept hypotheses.

        Row 0 is the first hypothesis without its hidden agent in the scene ("none"), then
        the present ones in order; once per `present` (L,) bool (read-only arrays).
        """
        key = present.tobytes()
        rows = self._kept_rows_memo.get(key)
        if rows is None:
            inverse = np.zeros(len(present), dtype=np.intp)
            inverse[present] = np.arange(1, int(present.sum()) + 1)
            keep = np.concatenate([np.flatnonzero(~present)[:1], np.flatnonzero(present)])
            inverse.setflags(write=False)
            keep.setflags(write=False)
            if len(self._kept_rows_memo) >= KEPT_ROWS_MAX:
                self._kept_rows_memo.clear()
            rows = self._kept_rows_memo[key] = (inverse, keep)
        return rows

    def curve_speed(self, route: Route) -> CurveSpeed | None:
        """The curve speed the robot assumes a human keeps on `route` (None: straight)."""
        if route.name not in self._curves:
            curve = CurveSpeed(route, HUMAN_CURVE_LAT_ACCEL_MPS2,
                               0.5 * self.model.vehicle.length_m)
            self._curves[route.name] = None if curve.is_straight else curve
        return self._curves[route.name]

    def yield_conflicts(self, route: Route) -> tuple:
        """The conflict zones `route` passes where it yields (sim/route_rules.route_conflicts).

        Computed once per route name (a human's path, paths.LanePaths).
        """
        conflicts = self._conflicts.get(route.name)
        if conflicts is None:
            conflicts = tuple(c for c in route_conflicts(route, self.road_map) if c.yields)
            self._conflicts[route.name] = conflicts
        return conflicts

    def yield_zones(self, route: Route, s0: float, scene: ScenePrediction) -> tuple:
        """The right of way the robot assumes a human on `route` at s0 [m] keeps (RoadRules).

        The conflict zones its route passes where it yields (sim/route_rules.route_conflicts)
        and that it has not yet left, each (polygon (V, 2) [m], priority (L, M) bool): the
        scene's cars travelling along one of the zone's priority lanes at the first predicted
        step (`priority_mask`) -- a hypothesised car on such a lane only in its hypothesis.
        The human's Q* then holds the conflict cost of entering the zone while one of them
        claims it (models/driver.RoadRules, `evaluate_candidates`' yield_zones): a human
        waiting at the zone for a car the robot cannot see is evidence for that car.

        Args:
            route: the human's route (its lane and onward, paths.LanePaths).
            s0: its arc length along the route [m].
            scene: the L scenes the human is modelled against (`hypothesis_scene`).
        """
        conflicts = self.yield_conflicts(route)
        if not conflicts or not scene.mask.any():
            return ()
        half = 0.5 * self.model.vehicle.length_m
        cars = scene.mask & ~scene.is_pedestrian  # (L, M)
        xy, heading = scene.xy[:, :, 0].reshape(-1, 2), scene.heading[:, :, 0].reshape(-1)
        zones = []
        for conflict in conflicts:
            if s0 - half > conflict.s_exit_m:  # already through it
                continue
            has_way = priority_mask(conflict.zone, self.road_map, xy, heading)
            has_way = has_way.reshape(cars.shape) & cars
            if has_way.any():
                zones.append((conflict.zone.polygon, has_way))
        return tuple(zones)

    def executed(self, v0: float) -> np.ndarray:
        """(A,) accelerations the candidate first actions execute as at speed v0 [m/s^2]."""
        return np.maximum(self._first_limited, -max(v0, 0.0) / DT_S)
