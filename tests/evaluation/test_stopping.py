"""Stop conditions end an episode at the first state where what it measures is settled, and the
steps before are those of the whole episode."""

from __future__ import annotations

import numpy as np

from marl_social.evaluation.run import run_episode
from marl_social.evaluation.stopping import PassedCrosswalk, RobotSees


def test_an_episode_cut_when_the_robot_has_passed_reports_the_same_time_to_pass():
    whole = run_episode(seed=3, pedestrian="none", robot_planner="social", max_cycles=100)
    cut = run_episode(seed=3, pedestrian="none", robot_planner="social", max_cycles=100,
                      until=PassedCrosswalk())
    n = len(cut.trace.times_s)
    assert n < len(whole.trace.times_s)
    assert cut.trace.times_s[-1] == whole.metrics["time_to_pass_s"]  # the state it is read at
    for key in ("time_to_pass_s", "p_pedestrian_at_crosswalk"):
        assert cut.metrics[key] == whole.metrics[key]
    assert np.array_equal(cut.trace.states, whole.trace.states[:n])
    assert np.array_equal(cut.trace.extras["p_pedestrian"], whole.trace.extras["p_pedestrian"][:n])


def test_an_episode_cut_at_the_robots_first_sight_ends_on_that_state():
    whole = run_episode(seed=1, pedestrian="crossing", robot_planner="social")
    cut = run_episode(seed=1, pedestrian="crossing", robot_planner="social",
                      until=RobotSees("pedestrian_0"))
    robot, ped = whole.trace.index("robot_0"), whole.trace.index("pedestrian_0")
    seen = np.asarray(whole.trace.visible)[:, robot, ped]
    first = int(np.argmax(seen))
    assert seen.any() and first > 0
    assert len(cut.trace.times_s) == first + 1
    assert np.array_equal(cut.trace.states, whole.trace.states[:first + 1])


def test_without_a_crosswalk_the_pass_condition_never_holds():
    whole = run_episode("t_intersection", seed=0, max_cycles=30)
    cut = run_episode("t_intersection", seed=0, max_cycles=30, until=PassedCrosswalk())
    assert len(cut.trace.times_s) == len(whole.trace.times_s) == 31
