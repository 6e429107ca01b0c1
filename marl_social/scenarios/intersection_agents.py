"""What every intersection scenario shares: the humans' and the robot's parameters, and the agents.

`IntersectionParams` holds the parameters of the human drivers and of the robot that the
intersection scenarios (t_intersection, signalized_intersection) have in common, with their
checks; each scenario's dataclass adds its own fields (and may change a default).
`human_spec` and `robot_spec` build the agents from them. Positions are metres, headings
radians, speeds m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marl_social.scenarios.base import (
    MAX_POS_NOISE_M,
    MAX_SENSOR_RANGE_M,
    MAX_SPEED_LIMIT_MPS,
    MAX_VEHICLE_SPEED_MPS,
    THETA_ROBOT,
    ScenarioParams,
)
from marl_social.sim.agent_spec import AgentSpec, SensorParams, VehicleParams
from marl_social.sim.costs import CostWeights


@dataclass(frozen=True)
class IntersectionParams(ScenarioParams):
    """The human drivers' and the robot's parameters of an intersection scenario (SI units).

    Attributes:
        human_beta: rationality of every human driver.
        human_theta: their cost weights (a mapping of feature names or 6 numbers in
            marl_social.sim.costs.FEATURE_NAMES order); empty = the default CostWeights.
        human_blind: the left-turners cannot see the eastbound lane(s) west of the junction
            (they turn whatever comes; they cannot act as sensors).
        human_expects_yield: every human expects a car that must give way in a conflict zone
            ahead of it (the robot at its stop line or red light, a left-turner before the
            oncoming lane) to stop before the zone if it can at 3 m/s^2, and predicts it at
            constant velocity only otherwise (models/yield_expectation.py); the robot's model
            of the humans assumes the same. False (the default): every other vehicle at
            constant velocity.
        human_sensor_range_m, human_half_fov_deg, human_pos_noise_m: every human's view.
        robot_speed_mps, robot_desired_speed_mps: the robot's initial and cruise speeds [m/s].
        robot_sensor_range_m, robot_half_fov_deg, robot_pos_noise_m: its view.
        robot_theta_hat: its model of the humans' cost weights (a mapping of feature names, 6
            numbers, or the path of a `marl-social irl fit` result); empty = its default
            (perception/belief/config.ROBOT_THETA_HAT).
        robot_beta_hat, robot_epsilon: its model of the humans' rationality and its tail
            threshold on beliefs.
        robot_sight_hold: a belief-based robot pulling out of a stop sign holds short of the
            lane it cannot see while a hidden car may come and a human that will tell is still
            coming (agents/robot/sight_hold.py; True, the default). False: it rolls out as its
            MPC plans (and forced V3 to brake hard in 4 of 50 `near` seeds of the
            T-intersection). It never holds at a signal.
        speed_limit_mps: legal limit [m/s].
    """

    human_beta: float = 5.0
    human_theta: tuple = ()
    human_blind: bool = False
    human_expects_yield: bool = False
    human_sensor_range_m: float = 80.0
    human_half_fov_deg: float = 60.0
    human_pos_noise_m: float = 0.05
    robot_speed_mps: float = 0.0
    robot_desired_speed_mps: float = 10.0
    robot_sensor_range_m: float = 80.0
    robot_half_fov_deg: float = 110.0
    robot_pos_noise_m: float = 0.05
    robot_theta_hat: tuple = ()
    robot_beta_hat: float = 0.3
    robot_epsilon: float = 0.05
    robot_sight_hold: bool = True
    speed_limit_mps: float = 13.9

    def __post_init__(self):
        super().__post_init__()
        self._normalize_cost_weights("human_theta")
        self._normalize_cost_weights("robot_theta_hat", fit_file=True)  # or an irl fit file
        for name in ("robot_speed_mps", "robot_desired_speed_mps"):
            self._check_range(name, 0.0, MAX_VEHICLE_SPEED_MPS, "m/s")
        self._check(self.human_beta >= 0.0, "human_beta", "must be >= 0 (inf allowed)")
        self._check(self.robot_beta_hat >= 0.0, "robot_beta_hat", "must be >= 0 (inf allowed)")
        self._check(0.0 <= self.robot_epsilon < 1.0, "robot_epsilon", "must be in [0, 1)")
        for name in ("human_sensor_range_m", "robot_sensor_range_m"):
            self._check_range(name, 0.0, MAX_SENSOR_RANGE_M, "m", low_open=True)
        for name in ("human_half_fov_deg", "robot_half_fov_deg"):
            self._check_range(name, 0.0, 180.0, "deg", low_open=True)
        for name in ("human_pos_noise_m", "robot_pos_noise_m"):
            self._check_range(name, 0.0, MAX_POS_NOISE_M, "m")
        self._check_range("speed_limit_mps", 0.0, MAX_SPEED_LIMIT_MPS, "m/s", low_open=True)


def human_spec(params: IntersectionParams, name: str, state, v_desired_mps: float,
               blind: tuple = ()) -> AgentSpec:
    """A human driver with the scenario's human cost weights, rationality and sensor.

    Args:
        params: the scenario's parameters.
        name: the agent's name.
        state: (4,) [x m, y m, heading rad, speed m/s] at reset.
        v_desired_mps: its desired speed [m/s].
        blind: polygons its sensor cannot see into (SensorParams.blind_regions).
    """
    p = params
    theta = CostWeights.from_any(p.human_theta) if p.human_theta else CostWeights()
    return AgentSpec(
        name, "vehicle", "human", np.asarray(state, dtype=np.float64),
        sensor=SensorParams(p.human_sensor_range_m, math.radians(p.human_half_fov_deg),
                            pos_noise_m=p.human_pos_noise_m, blind_regions=blind),
        vehicle=VehicleParams(), v_desired_mps=v_desired_mps, cost_weights=theta,
        planner={"beta": p.human_beta, "expects_yield": p.human_expects_yield},
    )


def robot_spec(params: IntersectionParams, x_m: float, front_y_m: float) -> AgentSpec:
    """robot_0 heading north (+y) in its lane, its front at front_y_m [m], centre at x_m [m].

    Args:
        params: the scenario's parameters.
        x_m: the lane's centre [m].
        front_y_m: where its front stands at reset [m].
    """
    p = params
    vehicle = VehicleParams()
    y = front_y_m - 0.5 * vehicle.length_m
    planner = {"beta_hat": p.robot_beta_hat, "epsilon": p.robot_epsilon,
               "human_expects_yield": p.human_expects_yield, "sight_hold": p.robot_sight_hold,
               "stage_settings": p.robot_stage_settings}
    if p.robot_theta_hat:
        planner["theta_hat"] = p.robot_theta_hat
    return AgentSpec(
        "robot_0", "vehicle", "robot",
        np.array([x_m, y, 0.5 * math.pi, p.robot_speed_mps]),
        sensor=SensorParams(p.robot_sensor_range_m, math.radians(p.robot_half_fov_deg),
                            pos_noise_m=p.robot_pos_noise_m),
        vehicle=vehicle, v_desired_mps=p.robot_desired_speed_mps, cost_weights=THETA_ROBOT,
        planner=planner,
    )
