"""The agents every intersection scenario builds the same way: human drivers and the robot.

The scenarios' parameter dataclasses (t_intersection, signalized_intersection) share the field
names these read: human_theta, human_beta, human_sensor_range_m, human_half_fov_deg,
human_pos_noise_m; robot_speed_mps, robot_sensor_range_m, robot_half_fov_deg,
robot_pos_noise_m, robot_desired_speed_mps, robot_beta_hat, robot_epsilon. Positions are
metres, headings radians, speeds m/s.
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.scenarios.base import THETA_ROBOT, ScenarioParams
from marl_social.sim.agent_spec import AgentSpec, SensorParams, VehicleParams
from marl_social.sim.costs import CostWeights


def human_spec(params: ScenarioParams, name: str, state, v_desired_mps: float,
               blind: tuple = ()) -> AgentSpec:
    """A human driver with the scenario's human cost weights, rationality and sensor.

    Args:
        params: the scenario's parameters (module docstring).
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
        planner={"beta": p.human_beta},
    )


def robot_spec(params: ScenarioParams, x_m: float, front_y_m: float) -> AgentSpec:
    """robot_0 heading north (+y) in its lane, its front at front_y_m [m], centre at x_m [m].

    Args:
        params: the scenario's parameters (module docstring).
        x_m: the lane's centre [m].
        front_y_m: where its front stands at reset [m].
    """
    p = params
    vehicle = VehicleParams()
    y = front_y_m - 0.5 * vehicle.length_m
    return AgentSpec(
        "robot_0", "vehicle", "robot",
        np.array([x_m, y, 0.5 * math.pi, p.robot_speed_mps]),
        sensor=SensorParams(p.robot_sensor_range_m, math.radians(p.robot_half_fov_deg),
                            pos_noise_m=p.robot_pos_noise_m),
        vehicle=vehicle, v_desired_mps=p.robot_desired_speed_mps, cost_weights=THETA_ROBOT,
        planner={"beta_hat": p.robot_beta_hat, "epsilon": p.robot_epsilon},
    )
