"""Right-of-way metrics on conflict zones (metrics/physical.py): yielded, time_to_pass_s and
others_max_decel_mps2, on hand-made T-intersection episodes."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.metrics.episode import episode_metrics
from marl_social.metrics.physical import others_max_decel, time_to_pass, yielded
from marl_social.scenarios.t_intersection import STOP_LINE_Y_M, TIntersection
from marl_social.sim.dynamics import DT_S
from marl_social.sim.trace import Trace

N_STEPS = 120  # 12 s


def _road_map():
    """The T-intersection with the robot and one eastbound car, `human_0`."""
    return TIntersection(n_humans=0, hidden_vehicle="near").build(
        np.random.default_rng(0)).road_map


def _trace(road_map, robot_s, car_s) -> Trace:
    """A trace in which robot_0 and human_0 are at arc lengths robot_s, car_s (T+1,) [m] of
    their routes (speeds and accelerations follow from them)."""
    names, series = ["robot_0", "human_0"], [robot_s, car_s]
    states = np.zeros((N_STEPS + 1, 2, 4))
    accel = np.zeros((N_STEPS, 2))
    for i, (name, s) in enumerate(zip(names, series)):
        xy, heading = road_map.routes[name].point_at(s)
        speed = np.gradient(s, DT_S)
        states[:, i] = np.column_stack([xy, heading, speed])
        accel[:, i] = np.diff(speed) / DT_S
    trace = Trace(names, ["robot", "human"], np.full(2, 2.45))
    trace.times_s = np.arange(N_STEPS + 1) * DT_S
    trace.states = states
    trace.active = np.ones((N_STEPS + 1, 2), bool)
    trace.visible = np.zeros((N_STEPS + 1, 2, 2), bool)
    trace.actions = np.zeros((N_STEPS, 2, 2))
    trace.accel_mps2 = accel
    trace.rewards = np.zeros((N_STEPS, 2))
    trace.collided = np.zeros((N_STEPS, 2), bool)
    return trace


def _robot_s(road_map, start_s: float) -> np.ndarray:
    """The robot waits at the stop line until start_s, then drives through at 5 m/s."""
    t = np.arange(N_STEPS + 1) * DT_S
    s_stop = road_map.routes["robot_0"].project(np.array([1.75, STOP_LINE_Y_M - 2.75]))[0]
    return s_stop + 5.0 * np.maximum(t - start_s, 0.0)


def _car_s(road_map, arrive_s: float) -> np.ndarray:
    """The eastbound car at 11 m/s, its centre at x = -4 m (the crossing's west edge) at arrive_s."""
    route = road_map.routes["human_0"]
    s_at = route.project(np.array([-4.0, -1.75]))[0]
    t = np.arange(N_STEPS + 1) * DT_S
    return s_at + 11.0 * (t - arrive_s)


def test_robot_pulling_out_just_before_the_car_did_not_yield():
    rm = _road_map()
    trace = _trace(rm, _robot_s(rm, 2.0), _car_s(rm, 3.5))
    assert not yielded(trace, rm, "robot_0")


def test_robot_going_after_the_car_has_passed_yielded():
    rm = _road_map()
    trace = _trace(rm, _robot_s(rm, 5.0), _car_s(rm, 2.0))
    assert yielded(trace, rm, "robot_0")


def test_robot_going_long_before_the_car_yielded():
    """The car arrives well after the robot has left the merge zone."""
    rm = _road_map()
    robot = _robot_s(rm, 0.5)
    trace = _trace(rm, robot, _car_s(rm, 20.0))
    passed = time_to_pass(trace, rm, "robot_0")
    assert np.isfinite(passed)
    car_far = _trace(rm, robot, _car_s(rm, passed + 2.5))
    assert yielded(car_far, rm, "robot_0")
    car_close = _trace(rm, robot, _car_s(rm, passed - 1.0))
    assert not yielded(car_close, rm, "robot_0")


def test_time_to_pass_is_when_the_robot_has_left_the_merge_zone():
    """Later start, later pass, by the same delay; nan if the robot never moves."""
    rm = _road_map()
    car = _car_s(rm, 30.0)
    early = time_to_pass(_trace(rm, _robot_s(rm, 1.0), car), rm, "robot_0")
    late = time_to_pass(_trace(rm, _robot_s(rm, 3.0), car), rm, "robot_0")
    assert late - early == pytest.approx(2.0, abs=DT_S + 1e-9)
    still = np.full(N_STEPS + 1, _robot_s(rm, 100.0)[0])
    assert np.isnan(time_to_pass(_trace(rm, still, car), rm, "robot_0"))


def test_braking_behind_the_robot_counts_as_forced():
    """The robot pulls out in front of the car, which brakes at 4 m/s^2 behind it: forced.
    The same braking with the robot still at the stop line: not forced (0)."""
    rm = _road_map()
    t = np.arange(N_STEPS + 1) * DT_S
    car = _car_s(rm, 3.0)
    brake_from = 2.0
    slow = np.where(t > brake_from, -0.5 * 4.0 * (t - brake_from) ** 2, 0.0)
    braking_car = car + slow
    forced = others_max_decel(_trace(rm, _robot_s(rm, 1.0), braking_car), rm, "robot_0")
    assert forced == pytest.approx(4.0, rel=0.05)
    waiting = others_max_decel(_trace(rm, _robot_s(rm, 100.0), braking_car), rm, "robot_0")
    assert waiting == 0.0


def test_a_human_braking_at_its_3_mps2_candidate_is_reported_at_3_mps2():
    """The effective acceleration is a speed difference over a step: a -3 m/s^2 action reads
    -3.000000000000007 m/s^2 from 11 m/s. Forced braking is reported rounded (3.0), so a
    threshold at 3 m/s^2 does not count it by rounding error."""
    rm = _road_map()
    trace = _trace(rm, _robot_s(rm, 1.0), _car_s(rm, 3.0))
    effective = ((11.0 - 3.0 * DT_S) - 11.0) / DT_S  # as envs/world.py records it
    assert effective != -3.0 and -effective > 3.0
    trace.accel_mps2[20:25, 1] = effective  # 2.0-2.5 s, the robot in the car's way
    assert others_max_decel(trace, rm, "robot_0") == 3.0


def test_episode_metrics_have_the_new_key_after_time_to_pass():
    rm = _road_map()
    metrics = episode_metrics(_trace(rm, _robot_s(rm, 5.0), _car_s(rm, 2.0)), rm)
    keys = list(metrics)
    assert keys.index("others_max_decel_mps2") == keys.index("time_to_pass_s") + 1
    assert metrics["yielded"] is True


def test_merging_behind_the_car_is_giving_way_cutting_in_front_is_not():
    """The car is already in the merge zone when the robot enters it: behind the car (it has
    passed the robot's path) the robot yielded; ahead of it (the car still to come) it did not."""
    rm = _road_map()
    behind = _trace(rm, _robot_s(rm, 1.5), _car_s(rm, 1.0))
    assert yielded(behind, rm, "robot_0")
    assert others_max_decel(behind, rm, "robot_0") == 0.0
    ahead = _trace(rm, _robot_s(rm, 0.5), _car_s(rm, 1.5))
    assert not yielded(ahead, rm, "robot_0")


def _braking_car(rm, arrive_s: float, brake_from_s: float, decel_mps2: float) -> np.ndarray:
    """The eastbound car of _car_s braking at decel_mps2 from brake_from_s on (down to rest)."""
    t = np.arange(N_STEPS + 1) * DT_S
    dt = np.clip(t - brake_from_s, 0.0, 11.0 / decel_mps2)
    return _car_s(rm, arrive_s) - 11.0 * np.maximum(t - brake_from_s, 0.0) + (
        11.0 * dt - 0.5 * decel_mps2 * dt ** 2)


def test_robot_rolling_out_towards_the_lane_forces_the_braking():
    """The robot rolls out of the stem at 2 m/s, its front not yet in the eastbound lane, while
    the car brakes at 5 m/s^2: forced (the robot will be in the lane within a second). Stopped
    with its front 1.5 m short of the lane, the same braking is not forced."""
    rm = _road_map()
    t = np.arange(N_STEPS + 1) * DT_S
    stop_s = _robot_s(rm, 100.0)[0]  # front 0.5 m behind the stop line, 2.5 m short of the lane
    rolling = stop_s + 2.0 * np.clip(t - 1.0, 0.0, 0.75)  # front 1.5 m short of the lane at 1.75 s
    braking = _braking_car(rm, 3.0, 1.5, 5.0)
    trace = _trace(rm, rolling, braking)
    trace.states[:, 0, 3] = np.where((t >= 1.0) & (t < 1.75), 2.0, 0.0)  # rolls, then stands
    assert others_max_decel(trace, rm, "robot_0") == pytest.approx(5.0, rel=0.05)
    standing = _trace(rm, rolling, _braking_car(rm, 3.0, 2.0, 5.0))
    standing.states[:, 0, 3] = np.where((t >= 1.0) & (t < 1.75), 2.0, 0.0)
    assert others_max_decel(standing, rm, "robot_0") == 0.0
