"""The app's episode is the CLI's: run_episode's states, step for step; frames are JSON."""

from __future__ import annotations

import json

import numpy as np
import pytest

from marl_social.evaluation.run import run_episode
from marl_social.teach.session import EpisodeConfig, EpisodeSession


@pytest.mark.parametrize("planner", ["social", "oracle"])
def test_the_session_plays_run_episodes_episode(planner):
    settings = {"robot.planner": planner, "human.beta": 3.0}
    session = EpisodeSession(EpisodeConfig(settings=settings, seed=4, max_cycles=40))
    states = [session.env.world.state.copy()]
    while not session.done:
        session.step()
        states.append(session.env.world.state.copy())
    trace = run_episode(seed=4, max_cycles=40, **settings).trace
    np.testing.assert_array_equal(np.asarray(trace.states), np.asarray(states))


def test_frames_carry_what_the_page_draws():
    session = EpisodeSession(EpisodeConfig(max_cycles=30))
    header = json.loads(json.dumps(session.header()))
    assert header["map"]["lanes"] and header["map"]["stripes"] and header["map"]["houses"]
    assert [a["role"] for a in header["agents"]] == ["robot", "human", "pedestrian"]
    for _ in range(20):
        frame = json.loads(json.dumps(session.step()))
    assert len(frame["agents"]) == 3 and frame["step"] == 20
    assert {i for i, _ in frame["fov"]} == {0, 1, 2}  # every agent's field of view
    belief = frame["belief"]
    assert belief["paths"][-1][0] == "none"
    assert sum(p for _, p in belief["paths"]) == pytest.approx(1.0, abs=1e-3)
    assert belief["spots"] and 0.0 <= belief["headline"] <= 1.0
    plan = frame["plan"]
    assert plan["speeds"] and len(plan["weights"]) == len(plan["speeds"]) == len(plan["labels"])


def test_the_cruise_robot_has_no_belief_nor_plan():
    session = EpisodeSession(EpisodeConfig(settings={"robot.planner": "cruise"}, max_cycles=5))
    frame = session.step()
    assert frame["belief"] is None and frame["plan"] is None


def test_a_blind_human_tells_the_robot_nothing():
    """At 2.8 s the seeing human's braking has told the robot; the blind one's has not."""
    beliefs = {}
    for blind in (False, True):
        session = EpisodeSession(EpisodeConfig(settings={"human.blind": blind}))
        for _ in range(28):
            frame = session.step()
        assert not frame["belief"]["perceived"]
        beliefs[blind] = frame["belief"]["headline"]
    assert beliefs[False] > 0.9 and beliefs[True] < 0.01
