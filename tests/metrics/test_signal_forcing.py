"""others_max_decel_mps2 at a signal: a car braking for its red light is not braking for the
robot standing beyond the light's stop line (hand-made signalized-intersection episodes)."""

from __future__ import annotations

import numpy as np

from marl_social.metrics.physical import others_max_decel
from marl_social.scenarios.signalized_intersection import SignalizedIntersection
from marl_social.sim.dynamics import DT_S
from marl_social.sim.signals import GREEN, RED
from marl_social.sim.trace import Trace

N_STEPS = 80  # 8 s
BRAKE_MPS2 = 4.0


def _episode(head_state: int | None) -> tuple[Trace, object]:
    """The cross car (human_1, eastbound) brakes at BRAKE_MPS2 from 10 m/s to rest 3.5 m before
    its stop line; the robot stands in the eastbound lane past the junction, ahead of it. Every
    signal head shows `head_state` (None: the trace records no signals)."""
    road_map = SignalizedIntersection(n_humans=1, n_cross=1).build(
        np.random.default_rng(0)).road_map
    cross = road_map.routes["human_1"]
    line = road_map.stop_lines[road_map.signal_heads[2].stop_line].segment
    s_stop = float(cross.segment_crossings(line)[0]) - 3.5
    t = np.arange(N_STEPS + 1) * DT_S
    v = np.maximum(10.0 - BRAKE_MPS2 * t, 0.0)
    s = s_stop - 10.0 ** 2 / (2 * BRAKE_MPS2) + np.concatenate([[0.0], np.cumsum(
        0.5 * (v[1:] + v[:-1]) * DT_S)])
    car_xy, car_heading = cross.point_at(s)
    robot_xy, robot_heading = cross.point_at(np.full_like(s, s_stop + 20.0))
    states = np.zeros((N_STEPS + 1, 3, 4))
    states[:, 0] = np.column_stack([robot_xy, robot_heading, np.zeros_like(s)])
    states[:, 1, :2] = [-1.75, 60.0]  # the left-turner, far away and still
    states[:, 1, 2] = -np.pi / 2
    states[:, 2] = np.column_stack([car_xy, car_heading, v])
    trace = Trace(["robot_0", "human_0", "human_1"], ["robot", "human", "human"],
                  np.full(3, 2.45))
    trace.times_s = t
    trace.states = states
    trace.active = np.ones((N_STEPS + 1, 3), bool)
    trace.visible = np.zeros((N_STEPS + 1, 3, 3), bool)
    trace.actions = np.zeros((N_STEPS, 3, 2))
    trace.accel_mps2 = np.zeros((N_STEPS, 3))
    trace.accel_mps2[:, 2] = np.diff(v) / DT_S
    trace.rewards = np.zeros((N_STEPS, 3))
    trace.collided = np.zeros((N_STEPS, 3), bool)
    if head_state is not None:
        trace.signal_states = np.full((N_STEPS + 1, len(road_map.signal_heads)), head_state,
                                      dtype=np.int8)
    return trace, road_map


def test_braking_for_a_red_light_is_not_forced_by_the_robot_beyond_it():
    trace, road_map = _episode(RED)
    assert others_max_decel(trace, road_map, "robot_0") == 0.0


def test_braking_on_green_for_the_robot_in_the_lane_is_forced():
    trace, road_map = _episode(GREEN)
    assert others_max_decel(trace, road_map, "robot_0") >= BRAKE_MPS2 - 1e-9


def test_without_recorded_signals_the_braking_counts():
    trace, road_map = _episode(None)
    assert others_max_decel(trace, road_map, "robot_0") >= BRAKE_MPS2 - 1e-9
