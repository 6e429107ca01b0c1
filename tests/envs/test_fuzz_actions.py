"""Property-based: any action of any dtype and shape is a ValueError naming the agent or a step
with finite observations and rewards; never NaN, never a hang."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import marl_social
from tests.fuzzing import fuzz

AGENTS = ("robot_0", "human_0", "pedestrian_0")
DTYPES = st.one_of(hnp.boolean_dtypes(), hnp.integer_dtypes(), hnp.unsigned_integer_dtypes(),
                   hnp.floating_dtypes(), hnp.complex_number_dtypes(), hnp.datetime64_dtypes(),
                   hnp.timedelta64_dtypes(), hnp.byte_string_dtypes(max_len=4),
                   hnp.unicode_string_dtypes(max_len=4))
ARRAYS = hnp.arrays(DTYPES, hnp.array_shapes(min_dims=0, max_dims=3, max_side=3))
SCALARS = st.one_of(st.none(), st.booleans(), st.integers(min_value=-(10**400),
                                                          max_value=10**400),
                    st.floats(), st.complex_numbers(), st.text(max_size=4),
                    st.binary(max_size=4))
PY_ACTIONS = st.one_of(SCALARS, st.lists(SCALARS, max_size=3), st.tuples(SCALARS, SCALARS),
                       st.dictionaries(st.text(max_size=2), SCALARS, max_size=2))


@pytest.fixture(scope="module")
def env():
    env = marl_social.parallel_env(max_cycles=50)
    yield env
    env.close()


def _check_step(env, agent, action):
    env.reset(seed=0)
    actions = {a: np.zeros(2) for a in env.agents}
    actions[agent] = action
    try:
        obs, rewards, *_ = env.step(actions)
    except (ValueError, TypeError) as err:
        assert agent in str(err), err
        return
    assert all(np.all(np.isfinite(o)) for o in obs.values())
    assert all(math.isfinite(r) for r in rewards.values())
    assert np.all(np.isfinite(env.world.state))


@pytest.mark.slow
@fuzz(150)
@given(agent=st.sampled_from(AGENTS), action=ARRAYS)
def test_numpy_actions_of_every_dtype_and_shape(env, agent, action):
    _check_step(env, agent, action)


@fuzz(150)
@given(agent=st.sampled_from(AGENTS), action=PY_ACTIONS)
def test_python_actions(env, agent, action):
    _check_step(env, agent, action)


@fuzz(60)
@given(agent=st.sampled_from(AGENTS),
       action=hnp.arrays(np.float64, 2, elements=st.floats(-1e308, 1e308)))
def test_finite_float_actions_always_step(env, agent, action):
    env.reset(seed=0)
    actions = {a: np.zeros(2) for a in env.agents}
    actions[agent] = action
    obs, rewards, *_ = env.step(actions)
    assert all(np.all(np.isfinite(o)) for o in obs.values())
    assert all(math.isfinite(r) for r in rewards.values())
    speed = env.world.state[env._index[agent], 3]
    assert 0.0 <= speed <= env.world.speed_max[env._index[agent]] + 1e-9


@fuzz(40)
@given(bad=ARRAYS)
def test_aec_env_recovers_from_any_rejected_action(bad):
    aec = marl_social.env(max_cycles=50)
    aec.reset(seed=0)
    agent = aec.agent_selection
    try:
        aec.step(bad)
    except (ValueError, TypeError) as err:
        assert agent in str(err)
        assert aec.agent_selection == agent
    for _ in range(2 * len(aec.possible_agents)):
        if not aec.agents:
            break
        done = aec.terminations[aec.agent_selection] or aec.truncations[aec.agent_selection]
        aec.step(None if done else np.zeros(2))
