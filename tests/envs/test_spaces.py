"""The global state (`state()`, `state_space`) and the observation bounds from physical limits."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pettingzoo.test import state_test

import marl_social
from marl_social.envs.policies import truth_tracks
from marl_social.envs.spaces import STATE_DIM
from marl_social.evaluation.run import randomized_overrides
from marl_social.scenarios import SCENARIOS
from marl_social.sim.observation import (
    EGO_DIM,
    EGO_INDEX,
    OBS_BOUND,
    SLOT_DIM,
    SLOT_INDEX,
    position_bounds,
)

CONFIGS = [(name, dict(variant)) for name, cls in SCENARIOS.items() for variant in cls.variants]
IDS = [f"{s}-{'-'.join(f'{k}={v}' for k, v in o.items()) or 'default'}" for s, o in CONFIGS]


@pytest.mark.parametrize(("scenario", "overrides"), CONFIGS, ids=IDS)
def test_pettingzoo_state_test(scenario, overrides):
    state_test(marl_social.env(scenario=scenario, **overrides),
               marl_social.parallel_env(scenario=scenario, **overrides), num_cycles=50)


def test_state_before_reset_is_a_clear_error():
    env = marl_social.parallel_env()
    with pytest.raises(RuntimeError, match=r"state\(\) called before reset"):
        env.state()
    aec = marl_social.raw_env()
    with pytest.raises(RuntimeError, match="before reset"):
        aec.state()


def test_state_rows_are_the_true_states_and_finished_agents_are_zero():
    """The built-in policies: the pedestrian crosses and leaves first, the cars go on."""
    env = marl_social.parallel_env(max_cycles=400)
    pols = marl_social.policies(env)
    obs, _ = env.reset(seed=3)
    for i, (_, policy) in enumerate(sorted(pols.items())):
        policy.reset(3 + i)
    n = len(env.possible_agents)
    saw_a_finish = False
    while env.agents:
        state = env.state().reshape(n, STATE_DIM)
        assert env.state().shape == env.state_space.shape == (n * STATE_DIM,)
        for i, agent in enumerate(env.possible_agents):
            if agent in env.agents:
                x, y, psi, v = env.world.state[i]
                np.testing.assert_allclose(state[i], [x, y, np.cos(psi), np.sin(psi), v, 1.0],
                                           rtol=1e-6, atol=1e-4)
            else:
                saw_a_finish = True
                assert not state[i].any()
        actions = {}
        for agent in env.agents:
            if pols[agent].needs_truth:
                pols[agent].observe_truth(truth_tracks(env, agent))
            actions[agent] = pols[agent](obs[agent])
        obs, *_ = env.step(actions)
    assert not env.state().any()  # every agent done: every row zero, active 0
    assert saw_a_finish


def test_bounds_are_the_physical_limits_not_a_flat_box():
    env = marl_social.parallel_env(max_cycles=200)
    space = env.observation_space("robot_0")
    assert np.all(np.abs(space.low) < OBS_BOUND) and np.all(np.abs(space.high) < OBS_BOUND)
    x0, x1, y0, y1 = env.road_map.extent
    reach = 20.0 * 0.1 * 200  # the fastest agent's top speed x step x max_cycles [m]
    ego_x, ego_y = EGO_INDEX["x"], EGO_INDEX["y"]
    np.testing.assert_allclose([space.low[ego_x], space.high[ego_x], space.low[ego_y],
                                space.high[ego_y]], [x0 - reach, x1 + reach, y0 - reach,
                                                     y1 + reach], atol=2.0)
    ranges = env.limits.sensor_range_max_m
    rays = slice(EGO_DIM + env.obs_layout.n_slots * SLOT_DIM, None)
    assert np.all(space.low[rays] == 0.0) and np.all(space.high[rays] == np.float32(ranges))
    slot0 = EGO_DIM
    for flag in ("present", "is_pedestrian"):
        assert (space.low[slot0 + SLOT_INDEX[flag]], space.high[slot0 + SLOT_INDEX[flag]]) == (0, 1)
    assert space.high[slot0 + SLOT_INDEX["id"]] == len(env.possible_agents)
    # an impossible observation is outside the space
    obs, _ = env.reset(seed=0)
    bad = obs["robot_0"].copy()
    bad[rays.start] = ranges + 1.0
    assert env.observation_space("robot_0").contains(obs["robot_0"])
    assert not space.contains(bad)
    # a longer episode lets agents go farther: the position bounds grow with it
    longer = marl_social.parallel_env(max_cycles=400).observation_space("robot_0")
    assert longer.high[EGO_INDEX["x"]] > space.high[EGO_INDEX["x"]]


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31 - 1), scenario=st.sampled_from(sorted(SCENARIOS)),
       scale=st.sampled_from([0.3, 1.0, 1e3]))
def test_observations_and_states_stay_in_their_spaces(seed, scenario, scale):
    """Randomized scenario parameters (the "wide" preset), random and saturating actions."""
    overrides = randomized_overrides(seed, "wide") if scenario == "occluded_crosswalk" else {}
    env = marl_social.parallel_env(scenario=scenario, max_cycles=120, **overrides)
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    while True:
        for agent, o in obs.items():
            space = env.observation_space(agent)
            outside = np.flatnonzero((o < space.low) | (o > space.high))
            assert not len(outside), (agent, outside, o[outside])
        assert env.state_space.contains(env.state())
        if not env.agents:
            break
        obs, *_ = env.step({a: scale * rng.uniform(-1, 1, 2) for a in env.agents})


def test_the_state_carries_every_signal_heads_true_state_one_hot():
    """A centralized critic sees the phase the robot may not: the signal block follows the rows."""
    from marl_social.envs.spaces import SIGNAL_STATE_DIM
    from marl_social.sim.signals import STATE_NAMES

    env = marl_social.parallel_env(scenario="signalized_intersection", max_cycles=300)
    env.reset(seed=0)
    n, heads = len(env.possible_agents), len(env.world.signal_heads)
    assert heads > 0
    assert env.state_space.shape == (n * STATE_DIM + heads * SIGNAL_STATE_DIM,)
    seen = set()
    while env.agents:
        block = env.state()[n * STATE_DIM:].reshape(heads, SIGNAL_STATE_DIM)
        truth = env.world.signal_states()
        np.testing.assert_array_equal(block.argmax(axis=1), truth)
        np.testing.assert_array_equal(block.sum(axis=1), 1.0)
        seen.update(STATE_NAMES[s] for s in truth)
        env.step({a: np.zeros(2) for a in env.agents})
    assert seen == set(STATE_NAMES)  # the plan cycles through red, yellow and green


def test_a_map_without_signals_has_no_signal_block():
    env = marl_social.parallel_env(scenario="occluded_crosswalk")
    env.reset(seed=0)
    assert env.state().shape == env.state_space.shape == (len(env.possible_agents) * STATE_DIM,)


def test_position_bounds_hold_zero_for_a_map_far_from_its_origin():
    """A real city's map lies hundreds of metres from its origin: an empty slot's 0 (and a
    gone agent's row) is still inside the bounds; a map about the origin keeps its own."""
    x, y = position_bounds((-420.0, -300.0, 500.0, 650.0), 30.0)
    assert x == (-450.0, 0.0) and y == (0.0, 680.0)
    assert position_bounds((-10.0, 10.0, -5.0, 5.0), 1.0) == ((-11.0, 11.0), (-6.0, 6.0))
