"""The signal phase belief: its Markov model, the robot's own head, the humans as evidence."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.evaluation.run import run_episode
from marl_social.perception.belief.phase import phase_transition
from marl_social.scenarios.signalized_intersection import SignalizedIntersection
from marl_social.sim.observation import SIGNAL_DIM, DecodedObservation

SCENARIO = "signalized_intersection"


def test_phase_transition_hands_over_by_duration():
    """Columns sum to 1; phase j keeps 1 - dt / D_j and hands the rest to the next one."""
    plan = SignalizedIntersection().signal_plan()
    t = phase_transition(plan, 0.1)
    np.testing.assert_allclose(t.sum(axis=0), 1.0)
    d = plan.durations_s
    np.testing.assert_allclose(np.diag(t), 1.0 - 0.1 / d)
    n = len(d)
    np.testing.assert_allclose(t[(np.arange(n) + 1) % n, np.arange(n)], 0.1 / d)


def _robot(**overrides):
    import marl_social

    env = marl_social.parallel_env(scenario=SCENARIO, **overrides)
    return marl_social.policies(env)["robot_0"], env


def test_own_head_rules_out_the_phases_that_would_show_it_otherwise():
    robot, env = _robot()
    belief = robot.phase_belief
    own = belief.own_heads[0]
    for state in (0, 1, 2):
        signals = np.zeros((env.obs_layout.n_signals, SIGNAL_DIM))
        signals[0, :2] = 1.0, own + 1.0
        signals[0, 2 + state] = 1.0
        decoded = DecodedObservation(np.zeros(8), np.zeros((0, 11)), np.zeros(0), signals)
        ll = belief.own_log_likelihood(decoded)
        consistent = belief.head_states[:, own] == state
        assert np.all(ll[consistent] == 0.0) and np.all(np.isneginf(ll[~consistent]))
    empty = DecodedObservation(np.zeros(8), np.zeros((0, 11)), np.zeros(0),
                               np.zeros((env.obs_layout.n_signals, SIGNAL_DIM)))
    assert np.all(belief.own_log_likelihood(empty) == 0.0)  # its head unseen: no information


def _p_protected_left(**overrides) -> np.ndarray:
    res = run_episode(SCENARIO, robot_planner="social", phase="protected_left", max_cycles=40,
                      **overrides)
    return np.asarray(res.trace.extras["phase_protected_left"])


@pytest.mark.slow
def test_belief_in_protected_left_rises_because_the_left_turners_accelerate():
    """Randomized queues (1-3 left-turners, 2-8 m behind their line, beta 2-30, no cross
    traffic): within 4 s the social robot's belief in the protected left exceeds 0.8 (its prior
    after its own red head: 0.24). Without left-turners nothing tells it: it stays below 0.35."""
    rng = np.random.default_rng(3)
    for seed in range(5):
        kw = {"n_humans": int(rng.integers(1, 4)), "human_start_m": float(rng.uniform(2.0, 8.0)),
              "human_beta": float(rng.uniform(2.0, 30.0)),
              "phase_elapsed_s": float(rng.uniform(0.0, 2.0)), "n_cross": 0}
        p = _p_protected_left(seed=seed, **kw)
        assert p.max() > 0.8, (seed, kw, p.max())
        assert p[0] < 0.3
    p = _p_protected_left(seed=0, n_humans=0, n_cross=0)
    assert p.max() < 0.35


def test_the_robot_never_reads_the_world_signal_state(monkeypatch):
    """The world's signal controller and state raise while the robot plans: it does not need
    them (it reads its own head from its observation only)."""
    import marl_social
    from marl_social.envs.world import World
    from marl_social.sim.signals import SignalController

    env = marl_social.parallel_env(scenario=SCENARIO, robot_planner="social", max_cycles=30)
    pols = marl_social.policies(env)
    obs, _ = env.reset(seed=1)
    for p in pols.values():
        p.reset(1)

    def forbidden(*args, **kwargs):
        raise AssertionError("the robot read the world's signal state")

    names = ("phase_at", "time_in_phase", "head_states")
    originals = {n: getattr(SignalController, n) for n in names}
    original_states = World.signal_states
    for _ in range(25):
        actions = {a: pols[a](obs[a]) for a in env.agents if a != "robot_0"}
        for n in names:
            monkeypatch.setattr(SignalController, n, forbidden)
        monkeypatch.setattr(World, "signal_states", forbidden)
        actions["robot_0"] = pols["robot_0"](obs["robot_0"])
        for n in names:
            monkeypatch.setattr(SignalController, n, originals[n])
        monkeypatch.setattr(World, "signal_states", original_states)
        obs, *_ = env.step(actions)
