"""The signalized intersection (paper Fig. 1 c): map, signals, humans obeying them, knobs."""

from __future__ import annotations

import numpy as np
import pytest

import marl_social
from marl_social.evaluation.run import run_episode
from marl_social.scenarios.signalized_intersection import SignalizedIntersection
from marl_social.sim.signal_rules import route_signal_lines
from marl_social.sim.signals import GREEN, RED

SCENARIO = "signalized_intersection"


def _layout(**overrides):
    return SignalizedIntersection(**overrides).build(np.random.default_rng(0))


def _front_past_line(res, name: str) -> np.ndarray:
    """(T+1,) bool: the agent's front bumper is past its route's signal line (and active)."""
    route = res.road_map.routes[name]
    s_line, _ = route_signal_lines(route, res.road_map)
    i = res.trace.index(name)
    s, _, _ = route.project(np.asarray(res.trace.states)[:, i, :2])
    half = 0.5 * res.specs[name].vehicle.length_m
    return (s + half > s_line[0]) & np.asarray(res.trace.active)[:, i]


def _head_states(layout, times_s, head_name: str) -> np.ndarray:
    """(T+1,) the state of the named head at each time."""
    heads = layout.road_map.signal_heads
    h = [x.name for x in heads].index(head_name)
    return np.array([layout.signals.head_states(t, heads)[h] for t in times_s])


def test_agents_and_their_names():
    """robot_0, the left-turners human_0.., then the cross cars; PettingZoo agents likewise."""
    assert [a.name for a in _layout(n_humans=2, n_cross=2).agents] == [
        "robot_0", "human_0", "human_1", "human_2", "human_3"]
    assert [a.name for a in _layout(n_humans=0, n_cross=0).agents] == ["robot_0"]
    env = marl_social.parallel_env(scenario=SCENARIO, n_humans=3, n_cross=1)
    assert env.possible_agents == ["robot_0", "human_0", "human_1", "human_2", "human_3"]
    assert env.obs_layout.n_signals == 3


@pytest.mark.parametrize("overrides, knob", [
    ({"phase": "ns_green"}, "phase"),
    ({"phase": "protected_left", "phase_elapsed_s": 10.0, "left_green_s": 10.0},
     "phase_elapsed_s"),
    ({"phase": "cross_green", "phase_elapsed_s": -1.0}, "phase_elapsed_s"),
    ({"n_humans": 4}, "n_humans"),
    ({"n_cross": 3}, "n_cross"),
    ({"yellow_s": 0.0}, "yellow_s"),
    ({"cross_gap_m": 2.0}, "cross_gap_m"),
    ({"cross_speed_mps": 25.0}, "cross_speed_mps"),
    ({"human_beta": -1.0}, "human_beta"),
    ({"human_theta": (1.0, 2.0)}, "human_theta"),
])
def test_bad_knobs_are_rejected_by_name(overrides, knob):
    with pytest.raises(ValueError, match=knob):
        SignalizedIntersection(**overrides)


def test_the_phase_at_the_start():
    """At t = 0 the heads show the variant's phase: protected_left (left arrow green, the robot's
    and the cross traffic's heads red) or cross_green (only the cross traffic's head green)."""
    names = ["southbound_left", "northbound", "eastbound"]
    for phase, expected in (("protected_left", [GREEN, RED, RED]),
                            ("cross_green", [RED, RED, GREEN])):
        layout = _layout(phase=phase)
        assert [h.name for h in layout.road_map.signal_heads] == names
        np.testing.assert_array_equal(
            layout.signals.head_states(0.0, layout.road_map.signal_heads), expected)


def _random_overrides(rng) -> dict:
    return {"cross_start_m": float(rng.uniform(30.0, 60.0)),
            "cross_speed_mps": float(rng.uniform(8.0, 14.0)),
            "human_beta": float(rng.uniform(2.0, 30.0)),
            "human_start_m": float(rng.uniform(0.5, 6.0)),
            "phase_elapsed_s": float(rng.uniform(0.0, 2.0)),
            "n_humans": int(rng.integers(1, 4)), "n_cross": int(rng.integers(1, 3))}


@pytest.mark.slow
def test_humans_stop_on_red_and_go_on_green():
    """Over randomized speeds, distances, queue lengths and rationalities: on protected_left no
    cross car passes its (red) line and the first left-turner turns; on cross_green no
    left-turner passes its (red) line and V3 drives through."""
    rng = np.random.default_rng(7)
    for seed in range(6):
        kw = _random_overrides(rng)
        cross = [f"human_{kw['n_humans'] + k}" for k in range(kw["n_cross"])]
        turners = [f"human_{k}" for k in range(kw["n_humans"])]
        res = run_episode(SCENARIO, seed=seed, robot_planner="aggressive", phase="protected_left",
                          max_cycles=120, **kw)
        for name in cross:
            assert not _front_past_line(res, name).any(), (seed, kw, name)
        assert _front_past_line(res, "human_0").any(), (seed, kw)
        res = run_episode(SCENARIO, seed=seed, robot_planner="aggressive", phase="cross_green",
                          max_cycles=120, **kw)
        for name in turners:
            assert not _front_past_line(res, name).any(), (seed, kw, name)
        assert _front_past_line(res, cross[0]).any(), (seed, kw)


@pytest.mark.slow
def test_yellow_is_handled_without_collisions():
    """The cross traffic's green ends while it approaches (yellow onset at random distances and
    speeds): nobody collides, no cross car enters the junction on red, and a car that stops
    does so without braking harder than its limit (the dilemma zone: stop if it comfortably
    can, else go on)."""
    rng = np.random.default_rng(11)
    for seed in range(6):
        kw = _random_overrides(rng)
        kw.update(phase="cross_green", cross_green_s=float(rng.uniform(2.5, 5.0)),
                  phase_elapsed_s=0.0, all_red_s=float(rng.uniform(1.0, 2.5)))
        layout = _layout(**kw)
        res = run_episode(SCENARIO, seed=seed, robot_planner="aggressive", max_cycles=150, **kw)
        assert not res.metrics["collision"], (seed, kw)
        states = _head_states(layout, res.trace.times_s, "eastbound")
        for k in range(kw["n_cross"]):
            past = _front_past_line(res, f"human_{kw['n_humans'] + k}")
            entered = np.flatnonzero(past[1:] & ~past[:-1]) + 1
            assert all(states[j] != RED for j in entered), (seed, kw, k)


def test_same_seed_same_episode():
    a = run_episode(SCENARIO, seed=5, max_cycles=40, robot_planner="aggressive")
    b = run_episode(SCENARIO, seed=5, max_cycles=40, robot_planner="aggressive")
    np.testing.assert_array_equal(np.asarray(a.trace.states), np.asarray(b.trace.states))
