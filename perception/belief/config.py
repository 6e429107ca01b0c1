"""Parameters of the robot's social perception (`BeliefConfig`, SI units).

Its own module so that the parts of the belief (own_sensors.py, social.py) and the belief that
combines them (pedestrian.py) all read it without importing each other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from marl_social.sim.costs import CostWeights

# The robot's own model of a human driver, not the simulated humans' weights (CostWeights'
# defaults): a driver that minds comfort twice as much and weighs a crosswalk conflict half as
# much (still far above everything else: it stops for a pedestrian).
ROBOT_THETA_HAT = CostWeights(tracking=1.0, speed=1.0, accel=0.2, jerk=0.2, safety=1.0,
                              crosswalk=500.0)
# The traffic speeds the robot considers, as fractions of the posted limit: the flow is at or
# below the limit; the grid knows nothing of the simulated humans' desired speed.
V_TRAFFIC_GRID_FRACTIONS = (0.55, 0.7, 0.85, 1.0)


@dataclass(frozen=True)
class BeliefConfig:
    """Parameters of the robot's social perception (SI units).

    Attributes:
        walk_speeds_mps: the speed bins of the hypothesised pedestrians [m/s].
        progress_step_m: length of a progress bin along a crosswalk [m] (None: only "steps
            off the curb now", the paper's pattern).
        curb_offset_m: how far from the curb a hypothesised pedestrian starts [m].
        p_detect: P(robot detects a pedestrian | it is in a visible part of the region).
        p_false_alarm: P(a crossing pedestrian is reported that is not there).
        accel_noise_mps2: the human's own execution noise about its chosen action [m/s^2]; the
            sigma of N(a_obs; u, sigma^2) is this and the robot's track error in quadrature
            (social.py).
        hazard_per_s: rate at which hidden pedestrians arrive at a crosswalk end, and at which
            hypothesised ones vanish [1/s] (hypotheses.motion_transition).
        floor: beliefs never drop below this before normalization.
        epsilon: the paper's tail threshold (for the planner; see `PedestrianBelief.live`).
        beta_hat: the robot's model of the humans' rationality.
        beta_grid_hat: if non-empty, beta_hat is not fixed: each tracked human's rationality is
            inferred on this grid jointly with the hidden state (a per-human belief b_i(beta),
            uniform at first; P(a_i | l, v) = sum_beta b_i(beta) P(a_i | l, v, beta), and
            b_i(beta) ∝ b_i(beta) sum_{l,v} b(l, v) P(a_i | l, v, beta)). An erratic human is
            then explained by a low beta and moves the pedestrian belief less.
        theta_hat: the robot's model of the humans' cost weights (default ROBOT_THETA_HAT).
        prior_present: prior mass of the present hypotheses, spread in proportion to the
            motion model's long-run distribution; None (the default): that long-run
            distribution itself (arrivals at hazard_per_s, crossings of a few seconds: about
            0.1 to 0.2 per crosswalk).
        v_traffic_grid_mps: grid of the traffic-speed belief [m/s]; empty (the default): the
            map's speed limit times V_TRAFFIC_GRID_FRACTIONS (`traffic_grid_mps`).
        human_range_m: range of the field of view the robot assumes a human has for the
            objects it reacts to besides the hypothesised pedestrian [m] (a generic driver's:
            SensorParams' default, not a scenario's).
        human_half_fov_rad: half-angle of that assumed field of view [rad] (likewise).
        human_expects_yield: the robot assumes a human expects a car that must give way in a
            conflict zone ahead of it (the robot itself included) to stop before the zone if it
            comfortably can (models/yield_expectation.py, the humans' DriverParams.
            expects_yield); False (the default): at constant velocity.
        walking_speed_min_mps: a seen pedestrian moving at least this fast along a hypothesis'
            walking direction is stepping onto the crosswalk [m/s].
        tail_dof: degrees of freedom nu of the Student-t kernel t_nu(a_obs - u; sigma) that
            scores an observed acceleration against each candidate action u
            (action_model.action_log_likelihood; inf: the normal kernel of eq. 10). Heavy tails:
            an acceleration the model does not predict (an emergency stop, a tracking glitch)
            favours the hypotheses whose actions lie nearest to it by a bounded factor.
        max_log_likelihood_ratio: bound on how far one observed action moves the log-odds
            between any two sets of hypotheses [nats] (social.bounded_log_likelihood).
        traffic_hazard_per_s: rate at which the traffic speed v_traffic changes [1/s] (the
            traffic-speed belief's Markov transition). 0 (the default): the flow's speed is one
            unknown of the episode; a human braking now is not read as the flow having just
            slowed down.
        cruise_speed_std_mps: spread of the humans' cruising speeds about the flow speed [m/s]:
            a tracked human's speed when its track first counts (min_track_steps) is evidence
            N(v_i; v_traffic, cruise_speed_std_mps^2) about the traffic speed, once per human
            (social.SocialLikelihood). A driver seen at 11 m/s is unlikely to want 7.6.
        marginalize_speed: the robot's model of a human is averaged over the robot's estimate
            of the human's speed (three Gauss-Hermite nodes of the track's velocity std along
            its route; action_model.speed_averaged_log_likelihood, ActionScoring.speed_std_mps):
            a best action that changes across ~0.1 m/s (whether it can still make its curve
            speed, or stop comfortably before a crosswalk) is not predicted with confidence on
            the wrong side of that change. On the crosswalk it keeps the belief from dithering
            about 0.5 while a human brakes with a pause (the claim "crosses 0.5 at most once");
            it makes the robot's decision about 1.4 times slower.
        min_track_steps: a human's acceleration is used once its track has been measured this
            many consecutive steps (a new Kalman track's velocity is still settling; with 3,
            a 1 m position noise gave false beliefs up to 0.54 in the first 0.6 s).
        track_accel_noise_mps2: process noise of the robot's default Kalman tracker [m/s^2]
            (lower: smoother a_obs, more lag; 1.5 keeps the a_obs noise below sigma = 1).
        track_pos_noise_m: position measurement noise std the robot's tracker assumes: the
            robot's own sensor's (agents.robot.planner.robot_configs passes spec.sensor's) [m].
        track_vel_noise_mps: velocity measurement noise std, likewise [m/s].
        vehicle_speed_fractions: the speed bins of hidden vehicles on the lanes with the right
            of way where they meet the robot's route, as fractions of the map's speed limit
            (conflicts.vehicle_hypotheses): the posted limit and a slower flow.
        vehicle_progress_step_m: length of a hidden vehicle's progress bin along its lane [m].
        vehicle_upstream_s: the progress bins reach this many seconds upstream of the point
            where the lane meets the robot's route, at the fastest speed bin [s] (beyond it
            a vehicle cannot reach the conflict within a planning horizon).
        vehicle_hazard_per_s: rate at which hidden vehicles arrive at those lanes' entry bins, and
            at which hypothesised ones vanish [1/s] (a main road's sparse traffic: with the
            defaults the prior puts about 0.2 on a hidden vehicle, spread over all such lanes).
        vehicle_negligible_mass: a hidden-vehicle hypothesis with less predicted belief is left
            out of the humans' modelled scenes (its social likelihood is that of "none"; it
            saves the humans' Q-values under hypotheses the robot's own sensors ruled out).
    """

    walk_speeds_mps: tuple = (0.9, 1.6)
    progress_step_m: float | None = 2.5
    curb_offset_m: float = 1.0
    p_detect: float = 0.95
    p_false_alarm: float = 0.01
    accel_noise_mps2: float = 0.5
    hazard_per_s: float = 0.02
    floor: float = 1e-6
    epsilon: float = 0.02
    beta_hat: float = 0.3
    beta_grid_hat: tuple = ()
    theta_hat: CostWeights = field(default_factory=lambda: ROBOT_THETA_HAT)
    prior_present: float | None = None
    v_traffic_grid_mps: tuple = ()
    human_range_m: float = 50.0
    human_half_fov_rad: float = math.radians(70.0)
    human_expects_yield: bool = False
    walking_speed_min_mps: float = 0.5
    tail_dof: float = 8.0
    max_log_likelihood_ratio: float = 4.0
    traffic_hazard_per_s: float = 0.0
    cruise_speed_std_mps: float = 1.5
    marginalize_speed: bool = True
    min_track_steps: int = 6
    track_accel_noise_mps2: float = 1.5
    track_pos_noise_m: float = 0.05
    track_vel_noise_mps: float = 0.1
    vehicle_speed_fractions: tuple = (0.7, 1.0)
    vehicle_progress_step_m: float = 10.0
    vehicle_upstream_s: float = 4.0
    vehicle_hazard_per_s: float = 0.05
    vehicle_negligible_mass: float = 1e-3

    def __post_init__(self):
        """Reject probabilities outside [0, 1], negative betas and non-positive noise/floor."""
        for name in ("p_detect", "p_false_alarm", "prior_present"):
            value = getattr(self, name)
            if value is not None and not 0.0 <= value <= 1.0:
                raise ValueError(f"BeliefConfig.{name} must be in [0, 1], got {value}")
        grid = np.asarray(self.beta_grid_hat, dtype=np.float64)
        if grid.ndim != 1 or not np.all(grid >= 0):  # also rejects NaN
            raise ValueError(f"BeliefConfig.beta_grid_hat must be a sequence of betas >= 0, "
                             f"got {self.beta_grid_hat!r}")
        if not (self.accel_noise_mps2 > 0 and self.hazard_per_s >= 0 and self.floor > 0
                and self.max_log_likelihood_ratio > 0 and self.tail_dof > 0
                and self.traffic_hazard_per_s >= 0 and self.cruise_speed_std_mps > 0):
            raise ValueError("BeliefConfig: need accel_noise_mps2 > 0, hazard_per_s >= 0, "
                             "floor > 0, max_log_likelihood_ratio > 0, tail_dof > 0, "
                             "traffic_hazard_per_s >= 0, cruise_speed_std_mps > 0")
        fractions = np.asarray(self.vehicle_speed_fractions, dtype=np.float64)
        if fractions.ndim != 1 or len(fractions) == 0 or not np.all(fractions > 0):
            raise ValueError("BeliefConfig.vehicle_speed_fractions must be a non-empty sequence "
                             f"of positive fractions, got {self.vehicle_speed_fractions!r}")
        if not (self.vehicle_progress_step_m > 0 and self.vehicle_upstream_s >= 0
                and self.vehicle_hazard_per_s >= 0 and 0 <= self.vehicle_negligible_mass < 1):
            raise ValueError("BeliefConfig: need vehicle_progress_step_m > 0, "
                             "vehicle_upstream_s >= 0, vehicle_hazard_per_s >= 0, "
                             "vehicle_negligible_mass in [0, 1)")

    def hazards_per_s(self) -> dict:
        """{kind: arrival and vanishing rate [1/s]} of the hidden agents (motion_transition)."""
        return {"pedestrian": self.hazard_per_s, "vehicle": self.vehicle_hazard_per_s}

    def traffic_grid_mps(self, speed_limit_mps: float) -> np.ndarray:
        """(V,) the traffic-speed grid [m/s]: v_traffic_grid_mps, or fractions of the limit.

        Args:
            speed_limit_mps: the map's speed limit [m/s].
        """
        if len(self.v_traffic_grid_mps):
            return np.asarray(self.v_traffic_grid_mps, dtype=np.float64)
        return float(speed_limit_mps) * np.asarray(V_TRAFFIC_GRID_FRACTIONS)
