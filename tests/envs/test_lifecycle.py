"""Wrapper lifecycle: out-of-order calls are a RuntimeError saying to call reset(), never a
stale answer or an unrelated exception; a copy taken mid-episode starts unreset."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import marl_social

OPS = ("reset", "step", "last", "pickle", "deepcopy", "run_to_end")


def _aec_step(env) -> None:
    if not env.agents:  # after the end: the env, not this helper, must answer
        env.step(np.zeros(2))
        return
    agent = env.agent_selection
    done = env.terminations[agent] or env.truncations[agent]
    env.step(None if done else np.zeros(2))


def _apply(env, op):
    """The op on an AEC env, or the env that replaces it (a copy)."""
    if op == "reset":
        env.reset(seed=0)
    elif op == "step":
        _aec_step(env)
    elif op == "last":
        env.last()
    elif op == "pickle":
        return pickle.loads(pickle.dumps(env))
    elif op == "deepcopy":
        return copy.deepcopy(env)
    elif op == "run_to_end":
        for _ in range(2000):
            if not env.agents:
                break
            _aec_step(env)
    return env


@settings(max_examples=25, deadline=None)
@given(st.sampled_from(["env", "raw_env"]), st.lists(st.sampled_from(OPS), max_size=7))
def test_aec_envs_answer_or_ask_for_reset(factory, ops):
    env = getattr(marl_social, factory)(max_cycles=15)
    for op in ops:
        try:
            env = _apply(env, op)
        except (RuntimeError, AttributeError) as err:  # AttributeError: the state before reset
            assert "reset" in str(err) and "\n" not in str(err)
    env.reset(seed=0)  # whatever came before, a reset gives a working env
    _aec_step(env)
    assert env.last()[0].shape == env.observation_space(env.agent_selection).shape


@pytest.mark.parametrize("factory", ["env", "raw_env"])
def test_a_copy_taken_mid_episode_asks_for_reset(factory):
    env = getattr(marl_social, factory)()
    env.reset(seed=0)
    _aec_step(env)
    for clone in (pickle.loads(pickle.dumps(env)), copy.deepcopy(env)):
        with pytest.raises(RuntimeError, match=r"call reset\(\)"):
            clone.last()
        with pytest.raises(RuntimeError, match=r"call reset\(\)"):
            clone.step(np.zeros(2))


@pytest.mark.parametrize("factory", ["env", "raw_env"])
def test_stepping_after_the_end_asks_for_reset(factory):
    env = _apply(getattr(marl_social, factory)(max_cycles=5), "reset")
    _apply(env, "run_to_end")
    with pytest.raises(RuntimeError, match=r"ended: call reset\(\)"):
        env.step(np.array([np.nan, 0.0]))


def test_the_homogeneous_wrapper_checks_order_and_agent_names():
    env = marl_social.parallel_env(homogeneous_spaces=True)
    with pytest.raises(RuntimeError, match=r"before reset\(\)"):
        env.step({})
    env.reset(seed=0)
    actions = {a: np.zeros(2) for a in env.agents}
    with pytest.raises(ValueError, match="unknown agent.*bogus"):
        env.step({**actions, "bogus": np.zeros(2)})
    env.step(actions)
