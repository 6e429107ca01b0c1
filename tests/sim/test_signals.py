"""Traffic signals: the plan's states, the fixed-time controller's clock, stop-or-go rules."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from marl_social.scenarios.signalized_intersection import SignalizedIntersection
from marl_social.sim.road_map import RoadMap, StopLine
from marl_social.sim.signal_rules import COMFORTABLE_DECEL_MPS2, must_stop, route_signal_lines
from marl_social.sim.signals import (
    GREEN,
    RED,
    YELLOW,
    SignalController,
    SignalHead,
    SignalPhase,
    SignalPlan,
)


def _plan(durations) -> SignalPlan:
    a, b, c = durations
    return SignalPlan(("ns", "ew"), (SignalPhase("ns_green", a, green=("ns",)),
                                     SignalPhase("ns_yellow", b, yellow=("ns",)),
                                     SignalPhase("ew_green", c, green=("ew",))))


def test_group_and_head_states_per_phase():
    plan = _plan((10.0, 3.0, 12.0))
    np.testing.assert_array_equal(plan.group_states(),
                                  [[GREEN, RED], [YELLOW, RED], [RED, GREEN]])
    heads = (SignalHead(np.zeros(2), 0.0, "ew", 0), SignalHead(np.ones(2), 0.0, "ns", 1))
    np.testing.assert_array_equal(plan.head_states(heads), [[RED, GREEN], [RED, YELLOW],
                                                            [GREEN, RED]])


def test_controller_runs_the_cycle_from_its_start_phase():
    """Over random durations and starts, the running phase and the time in it follow the cycle:
    the start phase until its remaining time is up, then each next phase for its duration."""
    rng = np.random.default_rng(0)
    for _ in range(50):
        durations = rng.uniform(0.5, 30.0, 3)
        plan = _plan(durations)
        start = int(rng.integers(0, 3))
        elapsed = float(rng.uniform(0.0, durations[start]))
        ctrl = SignalController(plan, start, elapsed)
        assert int(ctrl.phase_at(0.0)) == start
        assert float(ctrl.time_in_phase(0.0)) == pytest.approx(elapsed)
        remaining = durations[start] - elapsed
        t_next = remaining + 1e-6
        assert int(ctrl.phase_at(t_next)) == (start + 1) % 3
        assert float(ctrl.time_in_phase(t_next)) == pytest.approx(0.0, abs=1e-5)
        assert int(ctrl.phase_at(remaining - 1e-6)) == start
        # one whole cycle later: the same phase and the same time in it
        t = rng.uniform(0.0, 100.0)
        assert int(ctrl.phase_at(t)) == int(ctrl.phase_at(t + plan.cycle_s))
        assert float(ctrl.time_in_phase(t)) == pytest.approx(
            float(ctrl.time_in_phase(t + plan.cycle_s)), abs=1e-9)


@pytest.mark.parametrize("make, match", [
    (lambda: SignalPhase("p", 0.0), "duration_s"),
    (lambda: SignalPhase("p", 1.0, green=("a",), yellow=("a",)), "both green and yellow"),
    (lambda: SignalPlan(("a",), (SignalPhase("p", 1.0, green=("b",)),)), "unknown groups"),
    (lambda: SignalPlan(("a",), ()), "at least one phase"),
    (lambda: SignalController(_plan((1.0, 1.0, 1.0)), 3), "start_phase"),
    (lambda: SignalController(_plan((1.0, 1.0, 1.0)), 0, 1.0), "start_elapsed_s"),
    (lambda: SignalHead(np.zeros(3), 0.0, "a", 0), "position"),
    (lambda: RoadMap((), (), (), signal_heads=(SignalHead(np.zeros(2), 0.0, "a", 0),)),
     "signal_plan"),
    (lambda: RoadMap((), (), (), stop_lines=(StopLine(np.eye(2), "stop_sign"),),
                     signal_heads=(SignalHead(np.zeros(2), 0.0, "ns", 0, name="h"),),
                     signal_plan=_plan((1.0, 1.0, 1.0))), "not 'signal'"),
    (lambda: RoadMap((), (), (), stop_lines=(StopLine(np.eye(2), "signal"),),
                     signal_heads=(SignalHead(np.zeros(2), 0.0, "xx", 0, name="h"),),
                     signal_plan=_plan((1.0, 1.0, 1.0))), "group 'xx'"),
])
def test_bad_signal_definitions_are_rejected_by_name(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_must_stop_red_green_and_the_dilemma_zone():
    """Red: stop; green: go; yellow: stop exactly when v^2 / (2 d) <= the comfortable
    deceleration (random speeds and distances), go once past the line."""
    rng = np.random.default_rng(1)
    for v, d in zip(rng.uniform(0.0, 20.0, 200), rng.uniform(0.1, 80.0, 200)):
        assert must_stop(RED, v, d)
        assert not must_stop(GREEN, v, d)
        assert must_stop(YELLOW, v, d) == (v * v / (2.0 * d) <= COMFORTABLE_DECEL_MPS2)
        assert not must_stop(YELLOW, v, -d)
    with pytest.raises(ValueError, match="signal state"):
        must_stop(7, 1.0, 1.0)


def test_each_route_obeys_only_its_own_signal_line():
    """In the signalized intersection every agent's route crosses exactly one signal line, the
    one of its approach, ahead of its start."""
    layout = SignalizedIntersection(n_humans=1, n_cross=1).build(np.random.default_rng(0))
    rm = layout.road_map
    expected = {"robot_0": "northbound", "human_0": "southbound_left", "human_1": "eastbound"}
    for spec in layout.agents:
        route = rm.routes[spec.name]
        s, heads = route_signal_lines(route, rm)
        assert len(s) == 1, spec.name
        assert rm.signal_heads[int(heads[0])].name == expected[spec.name]
        s0, _ = route.project_point(*spec.initial_state[:2])
        assert s[0] > s0 + 0.5 * spec.vehicle.length_m
    assert math.isclose(rm.signal_plan.cycle_s, sum(p.duration_s for p in rm.signal_plan.phases))


def test_route_signal_lines_are_computed_once_per_route_and_map():
    """Repeated calls give the same lines, each its own arrays; another map is computed anew."""
    layout = SignalizedIntersection(n_humans=1, n_cross=1).build(np.random.default_rng(0))
    rm = layout.road_map
    route = rm.routes["robot_0"]
    s, heads = route_signal_lines(route, rm)
    s[:] = -1.0  # the caller's copy
    s2, heads2 = route_signal_lines(route, rm)
    assert np.all(s2 > 0.0) and np.array_equal(heads2, heads)
    assert s2.dtype == np.float64 and heads2.dtype == np.int64
    other = SignalizedIntersection(n_humans=1, n_cross=1).build(np.random.default_rng(0)).road_map
    assert np.array_equal(route_signal_lines(route, replace(other, signal_heads=()))[0],
                          np.zeros(0))


def test_signal_states_on_python_floats_are_the_numpy_reading():
    """DecodedObservation.signal_states as the numpy formula it replaced reads the block:
    np.rint of the index, np.argmax of the states (ties, NaN, infinities; float32 and 64)."""
    from marl_social.sim.observation import DecodedObservation

    rng = np.random.default_rng(4)
    values = np.array([0.0, -0.0, 1.0, 0.5, 0.25, np.nan, np.inf, -np.inf])
    for _ in range(3000):
        n = int(rng.integers(0, 6))
        dtype = rng.choice([np.float32, np.float64])
        signals = np.column_stack([rng.choice([0.0, 1.0, 0.6, 0.4], n),
                                   rng.integers(1, 9, n) + rng.choice([0.0, 0.5, -0.5, 0.3], n),
                                   rng.choice(values, (n, 3))]).astype(dtype)
        decoded = DecodedObservation(np.zeros(8), np.zeros((0, 11)), np.zeros(0), signals)
        seen = signals[signals[:, 0] > 0.5]
        want = {int(np.rint(row[1])) - 1: int(np.argmax(row[2:5])) for row in seen}
        assert decoded.signal_states() == want
