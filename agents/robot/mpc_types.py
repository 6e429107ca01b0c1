"""The contingency MPC's (mpc.py) configuration (horizon, bounds, weights; SI units) and result."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from marl_social.models.scene_prediction import ScenePrediction


@dataclass(frozen=True)
class MpcConfig:
    """The MPC's configuration (module docstring for the weights).

    Attributes:
        plan_dt_s: plan step [s].
        horizon_s: planning horizon [s] (holds a comfortable stop from the speed limit).
        trunk_s: the shared first segment [s].
        epsilon: tail threshold on beliefs.
        w_speed: weight on (v - v_ref)^2 [1 / (m/s)^2 / s].
        w_accel: weight on a^2 [1 / (m/s^2)^2 / s].
        w_jerk: weight on jerk^2 [1 / (m/s^3)^2 / s].
        jerk_max_mps3: hard jerk bound [m/s^3].
        lat_accel_max_mps2: lateral acceleration allowed on curves [m/s^2].
        min_gap_m: longitudinal gap kept to an object on the path [m].
        pedestrian_gap_m: longitudinal gap kept to a pedestrian [m].
        lateral_margin_m: clearance on each side of the robot for the corridor [m].
        pedestrian_margin_m: a pedestrian walking towards the robot's path is in its way
            within this clearance: it has the right of way on the carriageway (4.2 m: from the
            next lane's far edge); one standing on the curb or walking away is not [m].
        pedestrian_clearance_m: clearance on each side of the robot to any pedestrian, also
            one walking away: the robot goes again once it has left the crosswalk [m].
        time_headway_s: time headway to an object ahead [s].
        headway_ramp_s: the headway grows from 0 to time_headway_s over this time [s].
        terminal_headway_s: headway on the last plan step (room to stop beyond it) [s].
        pass_margin_s: the robot is past an object this long before it arrives [s].
        curvature_window_m: a route vertex this close to a step's guessed position bounds it [m].
        position_tolerance_m: a stay-behind bound may give way by up to this much, but no more
            than braking at half the limit needs (tracking noise on a bound it waits at) [m].
        rest_mps: below this speed the robot is at rest: it may always stay where it is [m/s].
        standstill_s: at rest with no plan going further than a bound's room, the robot
            brakes to rest over this time (standstill: it does not creep on) [s].
        comfort_decel_mps2: braking beyond this is penalized by w_comfort (soft bound) [m/s^2].
        w_comfort: weight on the braking beyond comfort_decel_mps2, squared
            [1 / (m/s^2)^2 / s].
        w_pull_up: weight of the pull-up term on (s - line)^2 while the robot drives up to a
            stop line it stands short of (`plan`'s pull_up_to_m) [1 / m^2 / s].
    """

    plan_dt_s: float = 0.25
    horizon_s: float = 6.0
    trunk_s: float = 0.5
    epsilon: float = 0.02
    w_speed: float = 1.0
    w_accel: float = 10.0
    w_jerk: float = 2.0
    jerk_max_mps3: float = 15.0
    lat_accel_max_mps2: float = 3.0
    min_gap_m: float = 1.0
    pedestrian_gap_m: float = 2.0
    lateral_margin_m: float = 0.5
    pedestrian_margin_m: float = 4.2
    pedestrian_clearance_m: float = 1.5
    time_headway_s: float = 1.0
    headway_ramp_s: float = 3.0
    terminal_headway_s: float = 1.5
    pass_margin_s: float = 2.5
    curvature_window_m: float = 5.0
    position_tolerance_m: float = 0.5
    rest_mps: float = 0.3
    standstill_s: float = 0.5
    comfort_decel_mps2: float = 2.5
    w_comfort: float = 100.0
    w_pull_up: float = 30.0

    def __post_init__(self):
        if not self.horizon_s > self.trunk_s >= self.plan_dt_s > 0.0:
            raise ValueError("MpcConfig: need horizon_s > trunk_s >= plan_dt_s > 0")

    @property
    def n_steps(self) -> int:
        """N plan steps."""
        return round(self.horizon_s / self.plan_dt_s)

    @property
    def n_trunk(self) -> int:
        """Shared first steps."""
        return round(self.trunk_s / self.plan_dt_s)

    @property
    def plan_times_s(self) -> np.ndarray:
        """(N,) times of the ends of the plan steps [s] (where scenes are predicted)."""
        return (np.arange(self.n_steps) + 1) * self.plan_dt_s

    def headway_s(self) -> np.ndarray:
        """(N,) the time headway of each step's stay-behind row [s]."""
        h = self.time_headway_s * np.minimum(1.0, self.plan_times_s / self.headway_ramp_s)
        h[-1] = max(h[-1], self.terminal_headway_s)
        return h


@dataclass(frozen=True)
class MpcResult:
    """The result of one MPC solve.

    Attributes:
        accel_mps2: the acceleration to apply now [m/s^2].
        feasible: a plan met every live branch's constraints (else: hardest braking).
        live: (L,) bool, the hypotheses planned for.
        weights: (L,) the renormalized beliefs (0 where not live).
        modes: per hypothesis, the chosen mode per object on its path (empty if not live).
        accel_plan: (B, N) accelerations of the B live branches [m/s^2] (NaN if infeasible).
        speed_plan: (B, N) their speeds at the end of each step [m/s].
        progress_plan: (B, N) their progress from the current position [m].
        cost: the expected cost J (inf if infeasible).
        jerk_relaxed: no plan met the jerk bound; the plan (if feasible) ignores it.
        contingency_given_way: feasible only with a contingency's own vehicle given way to a
            comfortable stop, or left out (mpc.py, module docstring).
        surprise_infeasible: infeasible, yet from the previous plan's state (one simulator
            step earlier) braking at most comfort_decel_mps2 would have kept behind every
            bound that made this plan infeasible (give_way.comfortable_stop_meets). Such a stop is
            at every plan step at least as far along as the hardest stop begun now (in one
            step the robot covers less than the two stopping distances differ), so against
            the same bounds this marks a plan not forced by them: the robot's own position
            estimate jumped, or the solver failed.
    """

    accel_mps2: float
    feasible: bool
    live: np.ndarray
    weights: np.ndarray
    modes: tuple
    accel_plan: np.ndarray
    speed_plan: np.ndarray
    progress_plan: np.ndarray
    cost: float
    jerk_relaxed: bool = False
    contingency_given_way: bool = False
    surprise_infeasible: bool = False


class BrakingStart(NamedTuple):
    """Where a braking manoeuvre starts, and how long before the plan it is judged by.

    Attributes:
        s_m: the robot's arc length along its route [m].
        v_mps: its speed [m/s].
        accel_mps2: its acceleration command then [m/s^2] (the braking ramps down from it).
        lead_s: how long before the plan's start it starts [s].
    """

    s_m: float
    v_mps: float
    accel_mps2: float
    lead_s: float


@dataclass(frozen=True)
class PlanRequest:
    """What one MPC solve plans for (ContingencyMpc.plan).

    Attributes:
        s0: the robot's arc length along its route (footprint centre) [m].
        v0: its speed [m/s].
        prev_accel: its previous acceleration command [m/s^2].
        v_ref_mps: reference speed [m/s].
        speed_limit_mps: hard speed limit [m/s].
        scene: L hypotheses of the others at config.plan_times_s.
        beliefs: (L,) probability of each hypothesis.
        static_outlines: (S, P, 2) the static polygons' outline points (corridor.
            static_outlines) [m].
        stop_at_m: the arc length the robot's centre must stay behind (a stop line not yet
            stopped at, agents/robot/stop.py; inf: none) [m].
        contingent: (L,) bool or factor in [0, 1] of the comfort weight: the hypotheses
            whose branches must brake comfortably (soft bound, config.comfort_decel_mps2):
            those not seen to be true, a pedestrian that may be hidden or may step off, or
            one that stepped off as prepared for (curb.py, `prepared_comfort`); None: every
            one.
        extra_objects: per hypothesis (L lists), objects on the path besides the scene's,
            e.g. the zone claims of cars with the right of way (agents/robot/right_of_way.py;
            None: none).
        pull_up_to_m: the arc length the robot's centre drives up to, drawn there by the
            pull-up term w_pull_up (s - line)^2: a robot at rest short of the stop line it
            must stop at pulls up to it within a couple of seconds instead of creeping (the
            speed term alone values distance, not arriving sooner; inf: no such term) [m].
    """

    s0: float
    v0: float
    prev_accel: float
    v_ref_mps: float
    speed_limit_mps: float
    scene: ScenePrediction
    beliefs: np.ndarray
    static_outlines: np.ndarray | None = None
    stop_at_m: float = np.inf
    contingent: np.ndarray | None = None
    extra_objects: list | None = None
    pull_up_to_m: float = np.inf
