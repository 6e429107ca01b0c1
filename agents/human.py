"""Human drivers as noisily-optimal planners (paper section III-B-1, eq. 7-8 and 11).

At every step a human driver computes, from its *own* tracks and the static map,

    Q*(x_hat, u) = min over continuations c of  sum_k theta^T phi(x_k, u_k)      (eq. 11)

(continuations that run into an object the human predicts are excluded: it never plans a
collision, whatever its weights);
for each first action u of a discrete set (held for `first_segment_s`, then continuation c
held to the end of the horizon; all candidates rolled out at once), and samples

    u ~ P(u) = softmax(-beta * Q*(x_hat, u))                                      (eq. 8)

with the episode's seeded generator; beta = inf is the argmin (perfectly rational), beta -> 0
uniform. Others are predicted at constant velocity from the human's tracks; with the planner
parameter `expects_yield` (DriverParams), a vehicle that must give way in a conflict zone ahead
of it and can stop before it at a comfortable deceleration is expected to
(models/yield_expectation.py). The human chooses its acceleration along its route
(path-velocity decomposition); pure pursuit steers.

The road's rules come from the static map along the human's own route
(sim/route_rules.py) and what it sees:

* stop signs: at a stop line it has not yet served, its plans must keep their front behind the
  line; once it has come to rest (speed <= STOPPED_SPEED_MPS) with its front within
  STOP_REACH_M of the line, the line is served and it may go;
* right of way: in a conflict zone it yields at, its cost adds the conflict of its own
  occupancy with that of every *tracked* object travelling along one of the zone's priority
  lanes (sim/costs.py), so it waits for oncoming traffic it sees and goes when the gap is
  large enough for its plans (gap acceptance emerges from Q*); traffic it does not see does
  not hold it back;
* bends: its plans keep the speed at or below sqrt(CURVE_LAT_ACCEL_MPS2 / curvature);
* traffic signals (sim/signal_rules.py): at the next signal line of its route it has not
  passed, it stops on red, and on yellow if it can at a comfortable deceleration
  (COMFORTABLE_DECEL_MPS2), else goes on (the dilemma zone); once it has chosen to go on
  yellow it keeps going through that line even if the head turns red. It knows a head's state
  only from its observation: a head it cannot see now (occluded, behind it, outside its view)
  it takes to show the state it last saw, and red if it has never seen it (it assumes it must
  stop).

On a straight route without stop lines or conflict zones nothing of this applies and the
decision is exactly the one without rules.

The decision model itself (`models/driver.py`, `models/boltzmann.py`) is shared: the robot's
model of a human calls `driver_q_values` with its own hypotheses and (theta_hat, beta_hat).
"""

from __future__ import annotations

import bisect
import itertools
import math

import numpy as np

from marl_social.agents.base import BoltzmannPolicy
from marl_social.agents.params import DriverParams, parse_planner_params
from marl_social.models.driver import (
    DriverModel,
    RoadRules,
    driver_choice_features,
    driver_q_values,
)
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.models.steering import pure_pursuit
from marl_social.models.yield_expectation import YieldExpectation
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.observation import Measurements, ObservationLayout
from marl_social.sim.road_map import RoadMap
from marl_social.sim.route_rules import (
    CurveSpeed,
    priority_mask,
    route_conflicts,
    stop_line_positions,
)
from marl_social.sim.signal_rules import must_stop, route_signal_lines
from marl_social.sim.signals import RED, YELLOW

STOPPED_SPEED_MPS = 0.1  # at or below this speed a driver is at rest [m/s]
# at rest with its front within this of a stop line, it has served it [m]: its plans cannot
# creep the last metres (the gentlest start from rest, 0 then +1 m/s^2, covers 3.1 m within
# the 3 s horizon, so it comes to rest about that far before the line)
STOP_REACH_M = 4.0
CURVE_LAT_ACCEL_MPS2 = 2.5  # lateral acceleration a driver accepts in a bend [m/s^2]


class BoltzmannDriver(BoltzmannPolicy):
    """A human driver policy: tracks what it sees, plans (eq. 11), samples (eq. 8).

    Built from its own AgentSpec (its cost weights; planner parameter "beta", see
    agents/params.DriverParams), the shared observation layout and the static map — nothing
    else.

    Args:
        spec: the driver's AgentSpec.
        layout: the shared observation layout.
        road_map: the static map.
        params: its planner parameters (default: parsed from spec.planner).
    """

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap,
                 params: DriverParams | None = None):
        params = params or parse_planner_params(DriverParams, spec)
        model = DriverModel(
            theta=spec.cost_weights, beta=params.beta,
            v_desired_mps=min(spec.v_desired_mps, road_map.speed_limit_mps),
            vehicle=spec.vehicle,
        )
        super().__init__(spec, layout, road_map, model)
        self.road_map = road_map
        self.stop_lines_s = stop_line_positions(self.route, road_map)  # (S,) [m]
        self.yield_conflicts = tuple(c for c in route_conflicts(self.route, road_map)
                                     if c.yields)
        self.yield_expectation = (YieldExpectation(road_map) if params.expects_yield
                                  and road_map.conflict_zones else None)
        curve = CurveSpeed(self.route, CURVE_LAT_ACCEL_MPS2, 0.5 * spec.vehicle.length_m)
        self.curve_speed = None if curve.is_straight else curve
        # (S,) [m] and (S,) head index of the signal lines on its route
        self.signal_lines_s, self.signal_line_heads = route_signal_lines(self.route, road_map)
        self._signal_lines = self.signal_lines_s.tolist()
        self._has_rules = bool(len(self.stop_lines_s) or self.yield_conflicts
                               or self.curve_speed is not None or len(self.signal_lines_s))
        self.record_decisions = False
        self.reset()

    def reset_state(self) -> None:
        """Forget the previous acceleration, the served stop lines and the recorded decisions."""
        self.prev_accel = 0.0
        self.stops_served = 0  # stop lines of its route it has come to rest at
        self.signals_seen: dict[int, int] = {}  # head index -> the state it last saw
        self._go_on_yellow: set[int] = set()  # signal lines it chose to pass on yellow
        self.decisions = []  # with record_decisions: (features, allowed, chosen index) per step
        self._pending_features = None
        self._tracks = None

    def predict(self, tracks) -> ScenePrediction:
        """The others at constant velocity, or, with `expects_yield`, as models/yield_expectation.py.

        The tracks are kept for the right of way.
        """
        self._tracks = tracks
        if self.yield_expectation is None or not len(tracks):
            return super().predict(tracks)
        xy = self.yield_expectation.predict_xy(
            tracks.xy, tracks.velocity, tracks.heading_rad, tracks.length_m, tracks.width_m,
            tracks.is_pedestrian, self._times)
        return ScenePrediction.from_tracks(tracks, self._times, predicted_xy=xy)

    def road_rules(self, s0: float, v: float) -> RoadRules | None:
        """The rules of this decision (see the module docstring); None where none applies.

        Args:
            s0: its arc length along its route [m].
            v: its speed [m/s].
        """
        if not self._has_rules:
            return None
        half_length = 0.5 * self.model.vehicle.length_m
        front = s0 + half_length
        while self.stops_served < len(self.stop_lines_s):
            line = self.stop_lines_s[self.stops_served]
            at_rest = v <= STOPPED_SPEED_MPS and line - front <= STOP_REACH_M
            if not (at_rest or front > line):
                break
            self.stops_served += 1
        stop = (float(self.stop_lines_s[self.stops_served])
                if self.stops_served < len(self.stop_lines_s) else None)
        signal_stop = self.signal_stop_m(front, v)
        if signal_stop is not None:
            stop = signal_stop if stop is None else min(stop, signal_stop)
        zones = []
        tracks = self._tracks
        if tracks is not None and len(tracks):
            for conflict in self.yield_conflicts:
                if s0 - half_length > conflict.s_exit_m:  # already through it
                    continue
                priority = priority_mask(conflict.zone, self.road_map, tracks.xy,
                                         tracks.heading_rad)
                if np.count_nonzero(priority):  # any (faster than .any() on a few)
                    zones.append((conflict.zone.polygon, priority[None]))
        return RoadRules(stop, tuple(zones), self.curve_speed)

    def signal_stop_m(self, front_m: float, v: float) -> float | None:
        """The signal line its front must stay behind now [m]; None: none (module docstring).

        Args:
            front_m: its front bumper's arc length along its route [m].
            v: its speed [m/s].
        """
        # the first line beyond its front (np.flatnonzero(lines > front)[0]) on Python floats
        k = next((k for k, line in enumerate(self._signal_lines) if line > front_m), None)
        if k is None or k in self._go_on_yellow:
            return None
        line = self._signal_lines[k]
        state = self.signals_seen.get(int(self.signal_line_heads[k]), RED)
        if not must_stop(state, v, line - front_m):
            if state == YELLOW:
                self._go_on_yellow.add(k)
            return None
        return line

    def q_values(self, decoded: Measurements, scene: ScenePrediction) -> np.ndarray:
        """(A,) Q* of each first acceleration (eq. 11) along the driver's route."""
        if len(self.signal_lines_s):
            self.signals_seen.update(decoded.signal_states())
        x, y, cos_psi, sin_psi, v = decoded.ego[:5].tolist()  # exact, as float() of each
        s0, _ = self.route.project_point(x, y)
        self._last_pose = (x, y, math.atan2(sin_psi, cos_psi), v, s0)
        rules = self.road_rules(s0, v)
        q = driver_q_values(self.model, self.route, s0, v, self.prev_accel, scene,
                            self.crosswalks, rules)[0]
        if self.record_decisions:  # computed apart: the decision itself is unchanged
            self._pending_features = driver_choice_features(
                self.model, self.route, s0, v, self.prev_accel, scene, self.crosswalks, rules)
        return q

    def choose(self, probabilities: np.ndarray) -> int:
        """Sample an action index from (A,) `probabilities` with the seeded generator.

        Inverse-CDF sampling: one uniform draw per call.
        """
        # np.cumsum and np.searchsorted(side="right") on a handful of Python floats: the same
        # sequential sums and comparisons
        cdf = list(itertools.accumulate(probabilities.tolist()))
        k = bisect.bisect_right(cdf, self.rng.random() * cdf[-1])
        return min(k, len(cdf) - 1)

    def act(self, chosen: int, obs: np.ndarray) -> np.ndarray:
        """The (2,) [acceleration m/s^2, steering rad] of first action `chosen`."""
        if self._pending_features is not None:
            self.decisions.append((*self._pending_features, chosen))
            self._pending_features = None
        accel = self.model.first_actions_mps2[chosen]
        self.prev_accel = accel
        x, y, psi, v, s_arc = self._last_pose
        steer = pure_pursuit(self.route, x, y, psi, v, s_arc, self.model.vehicle.wheelbase_m)
        return np.array([accel, steer], dtype=np.float32)
