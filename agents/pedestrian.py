"""Pedestrians as noisily-optimal planners walking their crossing route.

A pedestrian walks along its crossing route at one of a few speeds (0 = wait), Boltzmann over
its own cost, seeing vehicles only through its own field of view.

Cost (sim/costs.py, the same features as everyone): speed deviation from the pedestrian's
wish (its walking speed once it intends to cross, 0 before), acceleration, safety and the
crosswalk conflict with vehicles predicted at constant velocity from its own tracks. A pedestrian
has the right of way: it expects a vehicle to yield if that vehicle can still stop before the
crosswalk with a comfortable deceleration (`expected_yield_decel_mps2`), and then ignores it.
Gap acceptance emerges from the cost: a close, fast car that could not stop makes waiting
cheaper than walking into its path.
"""

from __future__ import annotations

import bisect
import itertools
import math

import numpy as np

from marl_social.agents.base import BoltzmannPolicy
from marl_social.agents.params import PedestrianPlannerParams, parse_planner_params
from marl_social.models.pedestrian import PedestrianModel, pedestrian_q_values
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.models.steering import walk_along
from marl_social.perception.tracking import TrackSet
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import Measurements, ObservationLayout
from marl_social.sim.road_map import Crosswalk, RoadMap, Route


def vehicles_expected_to_yield(tracks: TrackSet, crosswalk: Crosswalk, decel_mps2: float
                               ) -> np.ndarray:
    """(k,) bool: vehicle tracks heading towards the crosswalk that can still stop before it.

    A vehicle can stop if, braking at `decel_mps2`, v^2 / (2 decel) < the distance from its
    front to the crosswalk's near edge.

    Args:
        tracks: the pedestrian's k tracks.
        crosswalk: the crosswalk it is about to use.
        decel_mps2: the comfortable deceleration it expects a yielding driver to use [m/s^2].
    """
    if len(tracks) == 0:
        return np.zeros(0, dtype=bool)
    # a handful of tracks: the array formulas' operations one track at a time on Python floats
    # (the same IEEE results: rel . v is rel_x v_x + rel_y v_y, norms are sqrt(x x + y y))
    cx, cy = (float(c) for c in crosswalk.center)
    half_width = 0.5 * crosswalk.width_m
    two_decel = 2.0 * decel_mps2
    out = []
    for (x, y), (vx, vy), length, is_ped in zip(tracks.xy.tolist(), tracks.velocity.tolist(),
                                                tracks.length_m.tolist(),
                                                tracks.is_pedestrian.tolist()):
        rx, ry = cx - x, cy - y
        speed = math.sqrt(vx * vx + vy * vy)
        closing = (rx * vx + ry * vy) / max(speed, 1e-6)
        # distance from the car's front to the crosswalk's near edge, along its motion
        gap = math.sqrt(rx * rx + ry * ry) - half_width - 0.5 * length
        stopping = speed * speed / two_decel
        out.append(not is_ped and closing > 0.0 and stopping < gap)
    return np.array(out, dtype=bool)


def own_crosswalk(route: Route, crosswalks: tuple[Crosswalk, ...]) -> Crosswalk | None:
    """The crosswalk a pedestrian's route uses: the one holding most of its points 0.5 m apart.

    The first on a tie (the map's first when the route uses none); None without crosswalks.
    """
    if not crosswalks:
        return None
    points = route.point_at(np.arange(0.0, route.length_m, 0.5))[0]
    counts = [int(np.count_nonzero(cw.contains(points))) for cw in crosswalks]
    return crosswalks[int(np.argmax(counts))]


class BoltzmannPedestrian(BoltzmannPolicy):
    """A pedestrian policy (see module docstring).

    Args:
        spec: the pedestrian's AgentSpec.
        layout: the shared observation layout.
        road_map: the static map.
        params: its planner parameters ("crossing", "start_delay_s", "beta"; default: parsed
            from spec.planner, agents/params.PedestrianPlannerParams).
    """

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap,
                 params: PedestrianPlannerParams | None = None):
        params = params or parse_planner_params(PedestrianPlannerParams, spec)
        self.crossing = params.crossing
        self.start_delay_s = params.start_delay_s
        model = PedestrianModel(theta=spec.cost_weights, beta=params.beta,
                                v_walk_mps=max(spec.v_desired_mps, 0.1),
                                radius_m=spec.pedestrian.radius_m)
        super().__init__(spec, layout, road_map, model)
        self.own_crosswalk = own_crosswalk(self.route, self.crosswalks)
        self.reset()

    def reset_state(self) -> None:
        """Back to the episode start: time 0 s, standing."""
        self.time_s = 0.0
        self.prev_speed = 0.0

    def predict(self, tracks: TrackSet) -> ScenePrediction:
        """Constant-velocity scene without the vehicles it expects to yield to it."""
        if not self.crosswalks:
            return super().predict(tracks)
        yielding = vehicles_expected_to_yield(tracks, self.own_crosswalk,
                                              self.model.expected_yield_decel_mps2)
        return ScenePrediction.from_tracks(tracks, self._times, ~yielding[None])

    def q_values(self, decoded: Measurements, scene: ScenePrediction) -> np.ndarray:
        """(A,) Q of each walking speed in model.speeds_mps along its route."""
        wants_to_cross = self.crossing and self.time_s >= self.start_delay_s
        v_ref = self.model.v_walk_mps if wants_to_cross else 0.0
        x, y = self._last_xy = tuple(decoded.ego[:2].tolist())  # exact, as float() of each
        # walk_along's projection, for act (None: it projects itself)
        self._last_projection = None
        if self.route.n_segments == 1:  # project's arithmetic on Python floats
            s0, _ = self.route.project_point(x, y)
            self._last_projection = s0
        else:
            s0 = float(self.route.project(decoded.ego[:2].astype(np.float64))[0])
        return pedestrian_q_values(self.model, self.route, s0, v_ref, self.prev_speed,
                                   scene, self.crosswalks)[0]

    def choose(self, probabilities: np.ndarray) -> int:
        """Sample a speed index from (A,) `probabilities` with the seeded generator.

        `Generator.choice(len(p), p=p)` (its own stream consumption, kept apart from the
        driver's inverse-CDF draw so that seeded episodes stay identical), computed as choice
        computes it -- cdf = cumsum(p) / cdf[-1], one `random()` draw, searchsorted(side=
        "right") -- on Python floats; probabilities that choice would reject (negative, NaN,
        not summing to 1) go to choice itself.
        """
        p = probabilities.tolist()
        cdf = list(itertools.accumulate(p))  # np.cumsum: the same sequential sums
        total = cdf[-1]
        if not (abs(total - 1.0) <= 1e-9 and min(p) >= 0.0):
            return int(self.rng.choice(len(p), p=probabilities))
        return bisect.bisect_right([c / total for c in cdf], self.rng.random())

    def act(self, chosen: int, obs: np.ndarray) -> np.ndarray:
        """The (2,) walking action at speed model.speeds_mps[chosen] along its route."""
        self.time_s += DT_S
        speed = self.model.speeds_mps[chosen]
        self.prev_speed = speed
        x, y = self._last_xy  # of this observation, decoded by q_values
        return walk_along(self.route, x, y, speed, s_m=self._last_projection)
