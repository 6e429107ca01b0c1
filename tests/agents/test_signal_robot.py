"""The robot at signals: its own stop line (right turn on red), the per-phase MPC branches."""

from __future__ import annotations

import math

import numpy as np

from marl_social.agents.robot.phase_branches import stopping_prediction
from marl_social.agents.robot.signal_stop import SignalStops, turns_right_after
from marl_social.perception.belief.phase import SignalledCar, stops_per_phase
from marl_social.scenarios.signalized_intersection import SignalizedIntersection
from marl_social.sim.road_map import Route
from marl_social.sim.signals import GREEN, RED, YELLOW


def _robot_lines():
    layout = SignalizedIntersection().build(np.random.default_rng(0))
    rm = layout.road_map
    route = rm.routes["robot_0"]
    return route, rm, SignalStops(route, rm, 4.5)


def test_right_turn_on_red_after_coming_to_rest():
    """On red the robot's front must stay behind its line until it has rested there 0.5 s;
    then it may go (its route turns right). Green: no wall; yellow: a wall only if it can stop
    comfortably."""
    route, _, stops = _robot_lines()
    assert stops.right_on_red.tolist() == [True]
    assert turns_right_after(route, float(stops.lines_m[0]))
    head = int(stops.heads[0])
    line = float(stops.lines_m[0])
    s_front = line - 0.5
    s0 = s_front - 2.25
    for _ in range(4):  # at rest at the line, red: the wall holds for hold_s
        bound = stops.update(s0, 0.0, 0.1, {head: RED})
        assert bound <= s0 + 1e-9
    bound = stops.update(s0, 0.0, 0.1, {head: RED})
    bound = stops.update(s0, 0.0, 0.1, {})  # the head out of view: the last state it read
    assert math.isinf(bound)
    stops.reset()
    assert math.isinf(stops.update(s0 - 20.0, 10.0, 0.1, {head: GREEN}))
    stops.reset()
    assert not math.isinf(stops.update(s0 - 40.0, 10.0, 0.1, {head: YELLOW}))  # 40 m: stop
    stops.reset()
    assert math.isinf(stops.update(s0 - 5.0, 12.0, 0.1, {head: YELLOW}))  # 5 m at 12 m/s: go
    assert math.isinf(stops.update(s0 - 4.0, 12.0, 0.1, {head: RED}))  # committed on yellow
    stops.reset()
    assert not math.isinf(stops.update(s0 - 30.0, 5.0, 0.1, {}))  # never read: red


def test_a_car_predicted_to_stop_comes_to_rest_at_its_line():
    """Random speeds and distances: braking uniformly it never passes its line and ends at rest
    there when it can stop within the limit; otherwise there is no stopping prediction."""
    rng = np.random.default_rng(0)
    route = Route([[0.0, 0.0], [200.0, 0.0]])
    times = np.arange(1, 81) * 0.1
    for v, d in zip(rng.uniform(0.0, 15.0, 100), rng.uniform(0.5, 60.0, 100)):
        car = SignalledCar(0, route, 50.0, float(v), 50.0 + 2.25 + d, 0, 4.5)
        pred = stopping_prediction(car, times, 8.0)
        if v * v / (2.0 * d) > 8.0:
            assert pred is None
            continue
        xy, _ = pred
        front = xy[:, 0] + 2.25
        assert np.all(front <= car.line_s_m + 1e-9)
        assert np.all(np.diff(xy[:, 0]) >= -1e-12)
        if v / (v * v / (2.0 * d) + 1e-12) < times[-1] and v > 0.1:
            assert front[-1] == np.float64(front[-1]) and abs(front[-1] - car.line_s_m) < 1e-6


def test_stops_per_phase_follows_the_heads():
    layout = SignalizedIntersection().build(np.random.default_rng(0))
    rm = layout.road_map
    states = rm.signal_plan.head_states(rm.signal_heads)
    route = Route([[0.0, 0.0], [200.0, 0.0]])
    far = SignalledCar(0, route, 0.0, 10.0, 60.0, 2, 4.5)  # 57.75 m before its line
    near = SignalledCar(0, route, 0.0, 14.0, 10.0, 2, 4.5)  # 7.75 m at 14 m/s: cannot
    np.testing.assert_array_equal(stops_per_phase(states, far), states[:, 2] != GREEN)
    np.testing.assert_array_equal(stops_per_phase(states, near), states[:, 2] == RED)


def test_phase_branches_split_by_pattern_and_stop_the_cars_at_their_lines():
    """A cross car before its line and a hypothesised car that is that same car: the scene
    splits into "stops" and "drives on" by the phase belief (weights multiply), the stopping
    car ends at its line, and the duplicate of the tracked car is left out."""
    from marl_social.agents.robot.phase_branches import PhaseBranches
    from marl_social.models.scene_prediction import ScenePrediction
    from marl_social.perception.belief.paths import LanePaths
    from marl_social.perception.tracking import TrackSet

    layout = SignalizedIntersection().build(np.random.default_rng(0))
    rm = layout.road_map
    states = rm.signal_plan.head_states(rm.signal_heads)
    branches = PhaseBranches(rm, LanePaths(rm), states, 8.0)
    y = -5.25
    tracks = TrackSet(ids=np.array([3]), xy=np.array([[-40.0, y]]),
                      velocity=np.array([[10.0, 0.0]]), pos_std_m=np.zeros(1),
                      length_m=np.array([4.5]), width_m=np.array([1.8]),
                      is_pedestrian=np.zeros(1, bool), seen=np.ones(1, bool),
                      age_unseen_s=np.zeros(1), heading_rad=np.zeros(1))
    times = np.arange(1, 25) * 0.25
    scene = ScenePrediction.from_tracks(tracks, times)
    dup = np.array([-39.0, y]) + np.array([12.0, 0.0]) * times[:, None]  # the same car
    scene = scene.with_extra(dup[None], np.zeros((1, len(times))), np.full(1, 4.5),
                             np.full(1, 1.8), np.zeros(1, bool), np.ones(1, bool))
    phase = np.zeros(len(states))
    red, green = (int(np.flatnonzero(states[:, 2] == s)[0]) for s in (RED, GREEN))
    phase[red], phase[green] = 0.7, 0.3
    out, weights, contingent = branches.expand(scene, np.ones(1), np.zeros(1, bool), tracks,
                                               phase, times)
    assert out.mask.shape == (2, 2) and not out.mask[:, 1].any()  # duplicate left out
    np.testing.assert_allclose(sorted(weights), [0.3, 0.7])
    stop = int(np.argmax(weights))
    assert contingent.tolist() == [k != stop for k in range(2)]
    line_x = -9.5
    assert out.xy[stop, 0, -1, 0] + 2.25 <= line_x + 1e-6  # at rest at its line
    assert out.xy[1 - stop, 0, -1, 0] > line_x + 20.0  # drives on


def _robot_front_to_line(back_m: float, speed_mps: float, seed: int):
    """(times [s], front - line [m], speed [m/s], max decel [m/s^2]) of the social robot on red.

    The cross traffic absent, one left-turner; the robot's front starts back_m short of its
    red line at speed_mps.
    """
    from marl_social.evaluation.run import run_episode
    from marl_social.scenarios.signalized_intersection import ROBOT_LINE_Y_M

    res = run_episode("signalized_intersection", seed=seed, robot_planner="social",
                      phase="cross_green", n_cross=0, n_humans=1, robot_start_back_m=back_m,
                      robot_speed_mps=speed_mps, max_cycles=50)
    trace = res.trace
    states, t = np.asarray(trace.states), np.asarray(trace.times_s)
    i = trace.index("robot_0")
    front = states[:, i, 1] + 0.5 * res.specs["robot_0"].vehicle.length_m - ROBOT_LINE_Y_M
    return t, front, states[:, i, 3], res.metrics["max_decel_mps2"]


def test_the_robot_at_rest_short_of_its_red_line_has_stopped_and_turns_without_a_second_stop():
    """At rest 1.6-5 m short of its red line (the cross traffic absent), the robot has stopped:
    it completes its stop where it stands (hold_s, 0.5 s), then turns right on red without
    creeping up to the line and stopping again, its front past the line within 3.5 s, gently
    (before: it pulled up and stopped again, its front past the line after about 4.5 s)."""
    rng = np.random.default_rng(7)
    for back, seed in zip(rng.uniform(1.6, 5.0, 3), rng.integers(0, 10_000, 3)):
        t, front, v, max_decel = _robot_front_to_line(float(back), 0.0, int(seed))
        held = t[np.flatnonzero(v >= 0.1)[0]]  # it starts to move
        assert held >= 0.5, (back, held)
        assert np.all(np.abs(front[t <= held] + back) < 0.05), back  # where it stood
        past = np.flatnonzero(front > 0.0)
        assert len(past) and t[past[0]] <= 3.5, (back, t[past[:1]])
        assert np.all(v[(t > held) & (t <= t[past[0]])] >= 0.1), back  # no second stop
        assert max_decel <= 2.0, (back, max_decel)


def test_the_robot_rolling_up_to_its_red_line_pulls_up_to_it_and_stops_gently():
    """Rolling slowly (0.1-1.5 m/s) 2.5-5 m short of its red line, the robot drives up to the
    line and comes to rest at it (its front within 0.5 m) within 4 s, braking gently, never
    past the line before it has rested (without the pull-up term it settled 1.1-1.2 m short,
    in up to 4 s)."""
    rng = np.random.default_rng(8)
    for back, speed, seed in zip(rng.uniform(2.5, 5.0, 3), rng.uniform(0.1, 1.5, 3),
                                 rng.integers(0, 10_000, 3)):
        t, front, v, max_decel = _robot_front_to_line(float(back), float(speed), int(seed))
        at_rest = np.flatnonzero((v < 0.1) & (t > 0.0))
        assert len(at_rest) and t[at_rest[0]] <= 4.0, (back, speed, t[at_rest[:1]])
        assert abs(front[at_rest[0]]) <= 0.5, (back, speed, front[at_rest[0]])
        assert np.all(front[:at_rest[0] + 1] <= 0.05), (back, speed)
        assert max_decel <= 2.0, (back, speed, max_decel)
