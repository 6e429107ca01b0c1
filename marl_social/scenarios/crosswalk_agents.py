"""What every crosswalk scenario shares: the agents' parameters and the agents themselves.

`CrosswalkParams` holds the parameters of the robot, the human drivers and the pedestrian that
the crosswalk scenarios (occluded_crosswalk, map_scene) have in common, with their checks; each
scenario's dataclass adds its own fields (and may change a default). `robot_spec`, `human_spec`
and `pedestrian_spec` build the agents from them. Positions are metres, headings radians,
speeds m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marl_social.scenarios.base import (
    MAX_POS_NOISE_M,
    MAX_SENSOR_RANGE_M,
    MAX_VEHICLE_SPEED_MPS,
    THETA_ROBOT,
    ScenarioParams,
)
from marl_social.sim.agent_spec import AgentSpec, PedestrianParams, SensorParams, VehicleParams
from marl_social.sim.costs import CostWeights

PEDESTRIAN_VARIANTS = ("crossing", "waiting", "none")
# the pedestrian: keeps to its path and speed, and strongly prefers to stay on the crosswalk
THETA_PEDESTRIAN = CostWeights(tracking=1.0, speed=1.0, accel=0.01, jerk=0.0, safety=5.0,
                               crosswalk=1000.0)


@dataclass(frozen=True)
class CrosswalkParams(ScenarioParams):
    """The agents' parameters of a crosswalk scenario (SI units).

    Attributes:
        pedestrian: "crossing", "waiting" or "none".
        robot_speed_mps, human_speed_mps: initial speeds [m/s].
        robot_desired_speed_mps, human_desired_speed_mps: cruise speeds [m/s].
        human_lead_m: how far the human car starts ahead of the robot [m].
        pedestrian_speed_mps: walking speed when crossing [m/s].
        pedestrian_start_delay_s: time at which a crossing pedestrian steps off the curb [s].
        pedestrian_curb_offset_m: how far from the curb the pedestrian waits [m].
        robot_sensor_range_m, human_sensor_range_m, pedestrian_sensor_range_m: [m].
        robot_half_fov_deg, human_half_fov_deg, pedestrian_half_fov_deg: cone half-angles [deg].
        robot_pos_noise_m, human_pos_noise_m: measurement noise stds [m].
        human_beta, pedestrian_beta: rationality of the human driver / pedestrian planners
            (higher = more rational, inf = always the best action, 0 = uniformly random).
        human_theta: the human driver's cost weights (a mapping of feature names, or 6 numbers
            in marl_social.sim.costs.FEATURE_NAMES order); empty = the default CostWeights.
        robot_theta_hat, robot_beta_hat: the robot's model of the humans' cost weights (a
            mapping, 6 numbers, or the path of a `marl-social irl fit` result: its learned
            direction scaled to the default weights' norm, agents/irl.robot_model_from_fit;
            empty = the default CostWeights) and rationality (the social planner's beta_hat).
        robot_epsilon: the robot's tail threshold on beliefs (MPC and belief).
    """

    pedestrian: str = "crossing"
    robot_speed_mps: float = 11.5
    human_speed_mps: float = 11.5
    robot_desired_speed_mps: float = 11.5
    human_desired_speed_mps: float = 11.5
    human_lead_m: float = 20.0
    pedestrian_speed_mps: float = 1.3
    pedestrian_start_delay_s: float = 1.0
    pedestrian_curb_offset_m: float = 2.0
    robot_sensor_range_m: float = 40.0
    human_sensor_range_m: float = 60.0
    pedestrian_sensor_range_m: float = 60.0
    robot_half_fov_deg: float = 60.0
    human_half_fov_deg: float = 60.0
    pedestrian_half_fov_deg: float = 100.0
    robot_pos_noise_m: float = 0.05
    human_pos_noise_m: float = 0.05
    human_beta: float = 5.0
    pedestrian_beta: float = 5.0
    human_theta: tuple = ()
    robot_theta_hat: tuple = ()
    robot_beta_hat: float = 0.3
    robot_epsilon: float = 0.02

    def __post_init__(self):
        super().__post_init__()
        self._normalize_cost_weights("human_theta")
        self._normalize_cost_weights("robot_theta_hat", fit_file=True)  # or an irl fit file
        self._check(self.robot_beta_hat >= 0.0, "robot_beta_hat", "must be >= 0 (inf allowed)")
        self._check(0.0 <= self.robot_epsilon < 1.0, "robot_epsilon", "must be in [0, 1)")
        for name in ("human_beta", "pedestrian_beta"):
            self._check(getattr(self, name) >= 0.0, name, "must be >= 0 (inf allowed)")
        self._check(self.pedestrian in PEDESTRIAN_VARIANTS, "pedestrian",
                    f"must be one of {PEDESTRIAN_VARIANTS}")
        for name in ("robot_speed_mps", "human_speed_mps", "robot_desired_speed_mps",
                     "human_desired_speed_mps"):
            self._check_range(name, 0.0, MAX_VEHICLE_SPEED_MPS, "m/s")
        self._check_range("pedestrian_speed_mps", 0.1, 2.0, "m/s")
        for name in ("robot_sensor_range_m", "human_sensor_range_m", "pedestrian_sensor_range_m"):
            self._check_range(name, 0.0, MAX_SENSOR_RANGE_M, "m", low_open=True)
        for name in ("robot_half_fov_deg", "human_half_fov_deg", "pedestrian_half_fov_deg"):
            self._check_range(name, 0.0, 180.0, "deg", low_open=True)
        for name in ("robot_pos_noise_m", "human_pos_noise_m"):
            self._check_range(name, 0.0, MAX_POS_NOISE_M, "m")


def robot_spec(params: CrosswalkParams, state) -> AgentSpec:
    """robot_0 at state (4,) [x m, y m, heading rad, speed m/s], with its model of the humans."""
    p = params
    planner = {"beta_hat": p.robot_beta_hat, "epsilon": p.robot_epsilon,
               "stage_settings": p.robot_stage_settings}
    if p.robot_theta_hat:
        planner["theta_hat"] = p.robot_theta_hat
    return AgentSpec(
        "robot_0", "vehicle", "robot", np.asarray(state, dtype=np.float64),
        sensor=SensorParams(p.robot_sensor_range_m, math.radians(p.robot_half_fov_deg),
                            pos_noise_m=p.robot_pos_noise_m),
        vehicle=VehicleParams(), v_desired_mps=p.robot_desired_speed_mps,
        cost_weights=THETA_ROBOT, planner=planner,
    )


def human_spec(params: CrosswalkParams, name: str, state, blind: tuple = ()) -> AgentSpec:
    """A human driver at state (4,) with the scenario's human knobs.

    blind: polygons its sensor cannot see into (SensorParams.blind_regions).
    """
    p = params
    theta = CostWeights.from_any(p.human_theta) if p.human_theta else CostWeights()
    return AgentSpec(
        name, "vehicle", "human", np.asarray(state, dtype=np.float64),
        sensor=SensorParams(p.human_sensor_range_m, math.radians(p.human_half_fov_deg),
                            pos_noise_m=p.human_pos_noise_m, blind_regions=blind),
        vehicle=VehicleParams(), v_desired_mps=p.human_desired_speed_mps,
        cost_weights=theta, planner={"beta": p.human_beta},
    )


def pedestrian_spec(params: CrosswalkParams, xy, heading_rad: float) -> AgentSpec:
    """pedestrian_0 standing at xy (2,) [m] facing heading_rad: crossing or waiting."""
    p = params
    crossing = p.pedestrian == "crossing"
    return AgentSpec(
        "pedestrian_0", "pedestrian", "pedestrian",
        np.array([xy[0], xy[1], heading_rad, 0.0]),
        sensor=SensorParams(p.pedestrian_sensor_range_m, math.radians(p.pedestrian_half_fov_deg)),
        pedestrian=PedestrianParams(),
        v_desired_mps=p.pedestrian_speed_mps if crossing else 0.0,
        cost_weights=THETA_PEDESTRIAN,
        planner={"crossing": crossing, "start_delay_s": p.pedestrian_start_delay_s,
                 "beta": p.pedestrian_beta},
    )
