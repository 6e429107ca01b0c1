"""Built-in policies come from the planner registry: typed, validated parameters with errors
naming the agent and the field; only the oracle needs the true state; no policy holds the env."""

from __future__ import annotations

import inspect
from dataclasses import replace

import numpy as np
import pytest

import marl_social
from marl_social.agents.base import Policy
from marl_social.agents.params import DriverParams, PedestrianPlannerParams, RobotModelParams
from marl_social.agents.registry import (
    DEFAULT_PLANNER,
    PLANNERS,
    ROBOT_PLANNERS,
    build_planner,
    planner_params,
)
from marl_social.agents.robot.planner import RobotPlanner
from marl_social.envs.parallel import SocialDrivingEnv
from marl_social.envs.policies import make_policy
from marl_social.envs.world import World
from marl_social.scenarios.base import ScenarioParams


def _make(env, name, **planner):
    """make_policy for agent `name` of env with its planner parameters replaced by `planner`."""
    spec = replace(env.agent_specs[name], planner=planner)
    return make_policy(spec, env.obs_layout, env.road_map, env.possible_agents,
                       env.scenario.params.robot_planner)


def test_robot_planner_names_have_one_source():
    assert ROBOT_PLANNERS == ("social", "social+beta", "aggressive", "conservative", "oracle",
                              "cruise")
    assert set(DEFAULT_PLANNER.values()) | set(ROBOT_PLANNERS) == set(PLANNERS)
    with pytest.raises(ValueError, match="robot_planner.*must be one of"):
        ScenarioParams(robot_planner="socail")


def test_unknown_planner_names_the_agent_and_the_valid_planners(paper_env):
    spec = paper_env.agent_specs["robot_0"]
    with pytest.raises(ValueError, match=r"agent 'robot_0': unknown planner 'socail' for role "
                                         r"'robot'; valid: \['social', "):
        make_policy(spec, paper_env.obs_layout, paper_env.road_map, paper_env.possible_agents,
                    "socail")
    # a planner of another role is no planner for this agent
    with pytest.raises(ValueError, match="agent 'human_0': unknown planner 'social'"):
        build_planner("social", paper_env.agent_specs["human_0"], paper_env.obs_layout,
                      paper_env.road_map, paper_env.possible_agents)


@pytest.mark.parametrize("agent, planner, message", [
    ("human_0", {"beta": -1.0}, "agent 'human_0': planner parameter beta=-1.0: must be >= 0"),
    ("human_0", {"beta": "fast"}, "agent 'human_0': planner parameter beta='fast': expected a"),
    ("human_0", {"beta": float("nan")}, "agent 'human_0': planner parameter beta=nan: NaN"),
    ("human_0", {"betta": 1.0}, r"agent 'human_0': unknown planner parameter\(s\) \['betta'\]"),
    ("pedestrian_0", {"crossing": "yes"}, "'pedestrian_0': .* crossing='yes': expected a bool"),
    ("pedestrian_0", {"start_delay_s": -2.0}, "'pedestrian_0': .* start_delay_s=-2.0: must be"),
    ("robot_0", {"epsilon": 1.5}, r"'robot_0': planner parameter epsilon=1.5: must be in \[0, 1"),
    ("robot_0", {"beta_hat": True}, "'robot_0': planner parameter beta_hat=True: expected a"),
    ("robot_0", {"beta": 1.0}, r"agent 'robot_0': unknown planner parameter\(s\) \['beta'\]"),
])
def test_bad_planner_parameter_names_the_agent_and_the_field(paper_env, agent, planner, message):
    with pytest.raises(ValueError, match=message):
        _make(paper_env, agent, **planner)


def test_planner_parameters_are_typed(paper_env):
    specs = paper_env.agent_specs
    human = planner_params("boltzmann_driver", replace(specs["human_0"], planner={"beta": 3}))
    assert human == DriverParams(beta=3.0) and isinstance(human.beta, float)
    ped = planner_params("boltzmann_pedestrian", replace(
        specs["pedestrian_0"], planner={"crossing": np.bool_(False), "start_delay_s": 1}))
    assert ped == PedestrianPlannerParams(crossing=False, start_delay_s=1.0)
    robot = planner_params("social", replace(specs["robot_0"], planner={"theta_hat": {
        "crosswalk": 500.0}, "beta_hat": 2}))
    assert robot.theta_hat.crosswalk == 500.0 and robot.beta_hat == 2.0 and robot.epsilon is None
    assert planner_params("social", replace(specs["robot_0"], planner={})) == RobotModelParams()
    # the cruise car reads none of the robot's model of the humans, but still rejects a typo
    assert planner_params("cruise", specs["robot_0"]) is not None
    with pytest.raises(ValueError, match="agent 'robot_0': unknown planner parameter"):
        planner_params("cruise", replace(specs["robot_0"], planner={"epsilom": 0.1}))


@pytest.mark.parametrize("robot_planner", ROBOT_PLANNERS)
def test_needs_truth_only_for_the_oracle(robot_planner):
    env = marl_social.parallel_env(robot_planner=robot_planner)
    pols = marl_social.policies(env)
    for name, policy in pols.items():
        assert isinstance(policy, Policy)
        assert policy.needs_truth is (name == "robot_0" and robot_planner == "oracle"), name
    robot = pols["robot_0"]
    if isinstance(robot, RobotPlanner) and not robot.needs_truth:
        with pytest.raises(RuntimeError, match="needs_truth"):
            robot.observe_truth(None)


def _holds(obj, forbidden: tuple[type, ...], depth: int = 3, seen=None) -> bool:
    """Whether obj, its attributes or their contents (to `depth` levels) are of a forbidden
    type."""
    seen = set() if seen is None else seen
    if id(obj) in seen or depth < 0:
        return False
    seen.add(id(obj))
    if isinstance(obj, forbidden):
        return True
    if isinstance(obj, dict):
        children = list(obj.values())
    elif isinstance(obj, (list, tuple, set)):
        children = list(obj)
    elif hasattr(obj, "__dict__") and not isinstance(obj, type):
        children = list(vars(obj).values())
    else:
        return False
    return any(_holds(c, forbidden, depth - 1, seen) for c in children)


@pytest.mark.parametrize("robot_planner", ROBOT_PLANNERS)
def test_policies_never_receive_the_env(robot_planner):
    env = marl_social.parallel_env(robot_planner=robot_planner)
    obs, _ = env.reset(seed=0)
    pols = marl_social.policies(env)
    for i, (name, policy) in enumerate(pols.items()):
        policy.reset(i)
        if policy.needs_truth:
            policy.observe_truth(marl_social.envs.policies.truth_tracks(env, name))
        policy(obs[name])
        assert not _holds(policy, (SocialDrivingEnv, World)), name
    for entry in PLANNERS.values():
        assert "env" not in inspect.signature(entry.factory).parameters
    assert "env" not in inspect.signature(make_policy).parameters


def test_autopilot_feeds_the_oracle_its_truth():
    env = marl_social.autopilot(marl_social.parallel_env(robot_planner="oracle"),
                                controlled=["human_0"])
    env.reset(seed=1)
    for _ in range(5):
        env.step({a: np.zeros(2, np.float32) for a in env.agents})
    assert env._autopilots["robot_0"].needs_truth


@pytest.mark.parametrize("robot_planner", ROBOT_PLANNERS)
def test_policies_know_only_their_own_route_and_name(robot_planner):
    env = marl_social.parallel_env(robot_planner=robot_planner)
    for name, policy in marl_social.policies(env).items():
        maps = [v for v in vars(policy).values() if isinstance(v, type(env.road_map))]
        assert all(set(m.routes) == {name} for m in maps), name
        assert maps or name != "robot_0" or robot_planner == "cruise"
        belief = getattr(policy, "belief", None)
        if belief is not None:
            assert belief.agent_names == [name]


@pytest.mark.slow
@pytest.mark.parametrize("robot_planner", ROBOT_PLANNERS)
def test_every_planner_passes_a_pedestrian_waiting_on_the_curb(robot_planner):
    """0.5 m behind the curb a pedestrian is on the sidewalk: it blocks nobody."""
    from marl_social.evaluation.run import run_episode

    result = run_episode(pedestrian="waiting", pedestrian_curb_offset_m=0.5,
                         robot_planner=robot_planner, seed=0)
    assert np.isfinite(result.metrics["time_to_pass_s"]), robot_planner
    assert not result.metrics["collision"]
