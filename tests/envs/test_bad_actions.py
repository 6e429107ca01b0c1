"""Bad actions: a ValueError naming the agent; huge commands saturate; the AEC env recovers."""

from __future__ import annotations

import numpy as np
import pytest

import marl_social
from marl_social.sim.dynamics import saturate_pedestrian_action
from tests.helpers import zero_actions

NOT_REAL = [
    np.array([True, False]),
    [True, 0.0],
    np.array(["1", "0"]),
    ["1", "0"],
    np.array([1 + 0j, 0]),
    [1j, 0.0],
    np.array(["2020-01-01", "2020-01-02"], dtype="datetime64[D]"),
    np.array([1, 0], dtype="timedelta64[s]"),
    np.array([1.0, 0.0], dtype=object),
]


@pytest.mark.parametrize("bad", NOT_REAL, ids=lambda a: type(a).__name__ + str(
    getattr(a, "dtype", "")))
def test_non_real_dtypes_are_rejected_naming_the_agent(paper_env, bad):
    paper_env.reset(seed=0)
    actions = zero_actions(paper_env)
    actions["human_0"] = bad
    with pytest.raises(ValueError, match="human_0.*not numeric"):
        paper_env.step(actions)


@pytest.mark.parametrize("huge", [10**400, -(10**400)])
def test_huge_python_int_is_a_value_error(paper_env, huge):
    paper_env.reset(seed=0)
    actions = zero_actions(paper_env)
    actions["robot_0"] = [huge, 0]
    with pytest.raises(ValueError, match="robot_0.*beyond float range"):
        paper_env.step(actions)


def test_huge_python_int_through_autopilot():
    env = marl_social.autopilot(marl_social.parallel_env(), ["robot_0"])
    env.reset(seed=0)
    with pytest.raises(ValueError, match="robot_0.*beyond float range"):
        env.step({"robot_0": [10**400, 0]})


def test_integer_actions_are_accepted(paper_env):
    paper_env.reset(seed=0)
    actions = zero_actions(paper_env)
    actions["robot_0"] = [1, 0]
    actions["human_0"] = np.array([0, 0], dtype=np.int8)
    paper_env.step(actions)


@pytest.mark.parametrize("command", [[1e155, 0.0], [0.0, -1e200], [1e308, 1e308],
                                     [-1.7e308, 1.7e308]])
def test_huge_pedestrian_command_saturates_to_top_speed(command):
    out = saturate_pedestrian_action(np.array([command]), np.array([2.0]))
    assert np.all(np.isfinite(out))
    assert np.linalg.norm(out[0]) == pytest.approx(2.0)
    assert np.allclose(out[0] / 2.0, np.sign(command) / np.linalg.norm(np.sign(command)))


def test_huge_pedestrian_command_moves_the_pedestrian_at_top_speed(paper_env):
    paper_env.reset(seed=0)
    actions = zero_actions(paper_env)
    actions["pedestrian_0"] = np.array([0.0, 1e155])
    paper_env.step(actions)
    assert paper_env.world.state[2, 3] == pytest.approx(2.0)


def test_aec_rejected_action_does_not_jam_later_steps():
    aec = marl_social.env()
    aec.reset(seed=0)
    first = aec.agent_selection
    with pytest.raises(ValueError, match=first):
        aec.step(np.array([np.nan, 0.0]))
    assert aec.agent_selection == first  # not stored: the same agent acts again
    for _ in range(3 * len(aec.agents)):  # several full cycles step normally
        aec.step(np.zeros(2))
    assert aec.agents


def test_aec_action_for_a_done_agent_is_a_clear_error():
    aec = marl_social.env(max_cycles=1)
    aec.reset(seed=0)
    for _ in range(len(aec.agents)):
        aec.step(np.zeros(2))
    done = aec.agent_selection
    assert aec.terminations[done] or aec.truncations[done]
    with pytest.raises(ValueError, match=f"{done}.*done.*None"):
        aec.step(np.zeros(2))
    aec.step(None)  # the dead step still works
