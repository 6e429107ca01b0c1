"""Humans as explicit planners: they act on what they see, sample Boltzmann-rationally, and
cannot read the world."""

from __future__ import annotations

import math
import types

import numpy as np
import pytest

import marl_social
from marl_social.agents.human import BoltzmannDriver
from marl_social.agents.pedestrian import BoltzmannPedestrian
from marl_social.envs.parallel import SocialDrivingEnv
from marl_social.envs.world import World
from marl_social.models.boltzmann import boltzmann


def _run(max_steps=60, **overrides):
    """Every agent on its built-in planner (the robot on the cruise baseline: these tests are
    about the humans); per-step human accelerations and speeds."""
    env = marl_social.parallel_env(robot_planner="cruise", **overrides)
    pols = marl_social.policies(env)
    for i, p in enumerate(pols.values()):
        p.reset(i)
    obs, _ = env.reset(seed=0)
    accel, speed = [], []
    for _ in range(max_steps):
        if "human_0" not in env.agents:
            break
        obs, _, _, _, _ = env.step({a: pols[a](obs[a]) for a in env.agents})
        accel.append(env.world.accel_mps2[1])
        speed.append(env.world.state[1, 3])
    return np.array(accel), np.array(speed)


def test_human_brakes_because_it_sees_the_pedestrian():
    """Same scene: a human that sees the crossing pedestrian slows down within 2.5 s; blinded
    (its view of the crosswalk blocked) or without a pedestrian it keeps its speed."""
    sees, sees_v = _run(25, human_beta=math.inf)
    blind, blind_v = _run(25, human_beta=math.inf, human_blind=True)
    absent, absent_v = _run(25, human_beta=math.inf, pedestrian="none")
    assert sees.min() <= -2.0 and sees_v[-1] < 9.0
    assert blind.min() > -0.5 and blind_v[-1] > 11.0
    assert absent.min() > -0.5 and absent_v[-1] > 11.0


def test_human_ignores_a_waiting_pedestrian():
    accel, speed = _run(60, human_beta=math.inf, pedestrian="waiting")
    assert accel.min() > -0.5 and speed.min() > 11.0


def test_policy_depends_only_on_the_observation():
    """Policies built from two different true worlds give the same action distribution for the
    same observation; and no world or env is reachable from a policy."""
    env_a = marl_social.parallel_env(pedestrian="crossing")
    env_b = marl_social.parallel_env(pedestrian="crossing", human_lead_m=40.0,
                                     robot_speed_mps=5.0)
    obs_a, _ = env_a.reset(seed=1)
    env_b.reset(seed=2)
    for _ in range(5):  # different true worlds, moving
        env_b.step({a: np.zeros(2) for a in env_b.agents})
    pol_a = marl_social.policies(env_a)
    pol_b = marl_social.policies(env_b)
    for agent in ("human_0", "pedestrian_0"):
        pol_a[agent].reset(0)
        pol_b[agent].reset(0)
        np.testing.assert_array_equal(pol_a[agent].action_distribution(obs_a[agent]),
                                      pol_b[agent].action_distribution(obs_a[agent]))
        assert not _reaches(pol_a[agent], (World, SocialDrivingEnv))


def _reaches(obj, forbidden, depth=0, seen=None) -> bool:
    """Whether an instance of a forbidden type is reachable through attributes/containers."""
    seen = seen if seen is not None else set()
    if id(obj) in seen or depth > 6:
        return False
    seen.add(id(obj))
    if isinstance(obj, forbidden):
        return True
    children = []
    if isinstance(obj, dict):
        children = list(obj.values())
    elif isinstance(obj, (list, tuple, set)):
        children = list(obj)
    elif hasattr(obj, "__dict__"):
        children = list(vars(obj).values())
    return any(_reaches(c, forbidden, depth + 1, seen) for c in children)


@pytest.fixture
def driver_and_obs():
    env = marl_social.parallel_env()
    obs, _ = env.reset(seed=0)
    for _ in range(12):  # the pedestrian starts to walk: a scene with real trade-offs
        obs, *_ = env.step({"robot_0": np.zeros(2), "human_0": np.zeros(2),
                            "pedestrian_0": np.array([0.0, 1.3])})
    driver = BoltzmannDriver(env.agent_specs["human_0"], env.obs_layout, env.road_map)
    driver.reset(0)
    driver.action_distribution(obs["human_0"])
    return driver, obs["human_0"]


def test_beta_infinity_is_argmin_every_time(driver_and_obs):
    driver, _ = driver_and_obs
    q = driver.last_q
    p = boltzmann(q, math.inf)
    picks = {driver.choose(p) for _ in range(500)}
    assert picks == {int(np.argmin(q))}


def test_beta_zero_is_near_uniform(driver_and_obs):
    from scipy import stats  # here, not at collection: a slow import
    driver, _ = driver_and_obs
    p = boltzmann(driver.last_q, 1e-9)
    assert np.allclose(p, 1.0 / len(p), atol=1e-6)
    counts = np.bincount([driver.choose(p) for _ in range(9000)], minlength=len(p))
    assert stats.chisquare(counts).pvalue > 1e-3


def test_middle_beta_frequencies_match_softmax(driver_and_obs):
    """Chi-square goodness of fit of 20 000 samples against softmax(-beta Q), and the same test
    rejects the frequencies of a different beta (it has power)."""
    from scipy import stats  # here, not at collection: a slow import
    driver, _ = driver_and_obs
    q = driver.last_q
    beta = 1.0 / np.sort(q - q.min())[2]  # spreads mass over the three best actions
    p = boltzmann(q, beta)
    assert np.sort(p)[-3] > 0.05
    n = 20_000
    counts = np.bincount([driver.choose(p) for _ in range(n)], minlength=len(p))
    support = p * n >= 5
    expected = p[support] * n
    observed = counts[support]
    assert observed.sum() > 0.999 * n
    expected = expected * observed.sum() / expected.sum()
    assert stats.chisquare(observed, expected).pvalue > 1e-3
    wrong = boltzmann(q, 2.0 * beta)[support] * n
    wrong = wrong * observed.sum() / wrong.sum()
    assert stats.chisquare(observed, wrong).pvalue < 1e-6


def test_drivers_and_pedestrians_share_the_boltzmann_pipeline_with_their_own_samplers(
        driver_and_obs):
    """Both are BoltzmannPolicy (decode -> track -> predict -> Q -> sample); each keeps its own
    seeded sampler: the driver one inverse-CDF uniform draw, the pedestrian Generator.choice."""
    from marl_social.agents.base import BoltzmannPolicy

    driver, _ = driver_and_obs
    env = marl_social.parallel_env(pedestrian="crossing")
    ped = BoltzmannPedestrian(env.agent_specs["pedestrian_0"], env.obs_layout, env.road_map)
    assert isinstance(driver, BoltzmannPolicy) and isinstance(ped, BoltzmannPolicy)
    assert not driver.needs_truth and not ped.needs_truth
    p = np.array([0.1, 0.2, 0.3, 0.4])
    driver.reset(7)
    ped.reset(7)
    reference = np.random.default_rng(7)
    for _ in range(50):
        u = reference.random()
        assert driver.choose(p) == int(np.searchsorted(np.cumsum(p), u * p.sum(), side="right"))
    reference = np.random.default_rng(7)
    assert [ped.choose(p) for _ in range(50)] == [int(reference.choice(4, p=p))
                                                  for _ in range(50)]


def _pedestrian_first_speed(**overrides) -> float:
    # the pedestrian stands at the curb's edge: any step forward is onto the road
    env = marl_social.parallel_env(pedestrian="crossing", pedestrian_start_delay_s=0.0,
                                   pedestrian_beta=math.inf, pedestrian_curb_offset_m=0.3,
                                   **overrides)
    ped = BoltzmannPedestrian(env.agent_specs["pedestrian_0"], env.obs_layout, env.road_map)
    ped.reset(0)
    obs, infos = env.reset(seed=0)
    for _ in range(3):  # a few steps so its tracks know the cars' velocities
        action = ped(obs["pedestrian_0"])
        obs, *_ = env.step({"robot_0": np.zeros(2), "human_0": np.zeros(2),
                            "pedestrian_0": action})
    return float(np.linalg.norm(ped(obs["pedestrian_0"]))), infos["pedestrian_0"]["visible"]


def test_pedestrian_waits_for_a_close_fast_car():
    # robot 15 m from the crosswalk at 13 m/s: it cannot stop at 4 m/s^2 -> wait
    speed, seen = _pedestrian_first_speed(crosswalk_x_m=18.0, robot_speed_mps=13.0,
                                          human_lead_m=60.0)
    assert "robot_0" in seen
    assert speed == 0.0


def test_pedestrian_crosses_when_the_road_is_clear():
    # both cars far away (beyond its 60 m sight and able to stop anyway)
    speed, seen = _pedestrian_first_speed(crosswalk_x_m=120.0, human_lead_m=5.0,
                                          road_end_x_m=200.0)
    assert seen == []
    assert speed == pytest.approx(1.3, abs=0.05)


def test_pedestrian_crosses_in_front_of_a_car_that_can_stop():
    # the car is 40 m away at 11.5 m/s: it can stop comfortably, the pedestrian has priority
    speed, seen = _pedestrian_first_speed(crosswalk_x_m=45.0, human_lead_m=60.0)
    assert "robot_0" in seen
    assert speed == pytest.approx(1.3, abs=0.05)


def test_autopilot_exposes_only_the_controlled_agents():
    from pettingzoo.test import parallel_api_test

    env = marl_social.autopilot(marl_social.parallel_env(), controlled=["robot_0"])
    parallel_api_test(env, num_cycles=200)
    obs, _ = env.reset(seed=0)
    assert list(obs) == ["robot_0"]
    _, _, _, _, infos = env.step({"robot_0": np.zeros(2)})
    assert list(infos) == ["robot_0"]
    # the others moved on their own planners: the human is not where zero actions leave it
    assert env.unwrapped.world.state[1, 3] != 0.0
    with pytest.raises(ValueError, match="human_0"):
        env.step({"robot_0": np.zeros(2), "human_0": np.zeros(2)})
    with pytest.raises(ValueError, match="human_9"):
        marl_social.autopilot(marl_social.parallel_env(), controlled=["human_9"])


def test_stress_knobs_are_validated():
    with pytest.raises(ValueError, match="human_beta"):
        marl_social.parallel_env(human_beta=-1.0)
    with pytest.raises(ValueError, match="human_theta.*unknown cost features"):
        marl_social.parallel_env(human_theta={"sped": 1.0})
    env = marl_social.parallel_env(human_theta=[1, 2, 0.1, 0.1, 1, 500], human_beta=0.5)
    spec = env.agent_specs["human_0"]
    assert spec.cost_weights.speed == 2.0 and spec.planner["beta"] == 0.5


def _randomized_overrides(seed: int) -> dict:
    rng = np.random.default_rng(seed)
    return {
        "pedestrian_start_delay_s": float(rng.uniform(0.0, 2.0)),
        "pedestrian_speed_mps": float(rng.uniform(1.1, 1.6)),
        "human_lead_m": float(rng.uniform(15.0, 30.0)),
        "human_speed_mps": float(rng.uniform(10.0, 13.0)),
    }


@pytest.mark.slow
def test_rational_humans_never_hit_a_crossing_pedestrian_200_seeds():
    """200 seeded, randomized occluded_crosswalk episodes, every agent on its built-in planner
    (robot: cruise baseline), rational humans (beta = 50): no human-pedestrian collision. Each
    episode runs until the human has passed the crosswalk (stopping.PassedCrosswalk), at most
    9 s (~27 % of the steps fewer than 9 s each; the same hits and brakes on these seeds)."""
    from marl_social.evaluation.stopping import PassedCrosswalk

    hits, yields = [], 0
    for seed in range(200):
        env = marl_social.parallel_env(pedestrian="crossing", human_beta=50.0, max_cycles=90,
                                       robot_planner="cruise",
                                       **_randomized_overrides(seed))
        pols = marl_social.policies(env)
        for i, p in enumerate(pols.values()):
            p.reset(seed * 10 + i)
        obs, _ = env.reset(seed=seed)
        braked, passed = False, PassedCrosswalk("human_0")
        while env.agents:
            obs, _, _, _, infos = env.step({a: pols[a](obs[a]) for a in env.agents})
            braked |= env.world.accel_mps2[1] < -1.0
            if "pedestrian_0" in infos["human_0"]["collided_with"] if "human_0" in infos else False:
                hits.append(seed)
            if passed(env):
                break
        yields += braked
    assert hits == []
    # the test has teeth only if pedestrians really cross in front of the humans: in most
    # episodes the human must brake for one (measured 143 of 200, 2026-12-03; the rest cross
    # behind it)
    assert yields >= 120


def test_human_passes_a_pedestrian_waiting_just_behind_the_curb():
    """A pedestrian 0.5 m behind the curb is on the sidewalk, not on the crosswalk: the human
    drives past it without slowing by 1 m/s (a few short brakes come from its noisy
    constant-velocity prediction of the standing pedestrian, the humans' own perception)."""
    _, speed = _run(60, human_beta=math.inf, pedestrian="waiting",
                    pedestrian_curb_offset_m=0.5)
    assert speed.min() > 10.5 and speed[-1] > 11.0


def _robot_observations(n_steps=30):
    """The robot's observations of a crossing episode (every agent on its built-in planner)."""
    env = marl_social.parallel_env(pedestrian="crossing", robot_planner="cruise")
    pols = marl_social.policies(env)
    for i, p in enumerate(pols.values()):
        p.reset(i)
    obs, _ = env.reset(seed=3)
    out = []
    for _ in range(n_steps):
        out.append(obs["robot_0"].copy())
        obs, *_ = env.step({a: pols[a](obs[a]) for a in env.agents})
    return out


def _differences(a, b, path="policy", seen=None) -> list[str]:
    """Where two policy objects differ (attributes, containers, arrays), recursively."""
    seen = set() if seen is None else seen
    if (id(a), id(b)) in seen:
        return []
    seen.add((id(a), id(b)))
    if type(a).__module__.split(".")[0] == "osqp" and type(a) is type(b):
        # a QP solver handle: opaque, and it keeps wall-clock timings of its last solve; what
        # it computes is compared through the planner's own arrays (last_result, ...)
        return []
    if type(a) is not type(b):
        return [f"{path}: {type(a).__name__} != {type(b).__name__}"]
    if isinstance(a, np.ndarray):
        same = a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
        return [] if same else [path]
    if isinstance(a, dict):
        if list(a) != list(b):
            return [f"{path}: keys {list(a)} != {list(b)}"]
        return [d for k in a for d in _differences(a[k], b[k], f"{path}[{k!r}]", seen)]
    if isinstance(a, (list, tuple)):
        if len(a) != len(b):
            return [f"{path}: length {len(a)} != {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b))
                for d in _differences(x, y, f"{path}[{i}]", seen)]
    if hasattr(a, "__dict__") and not isinstance(a, (type, types.FunctionType,
                                                     types.MethodType)):
        return _differences(vars(a), vars(b), path, seen)
    if isinstance(a, float) and math.isnan(a) and math.isnan(b):
        return []
    try:
        return [] if a == b else [f"{path}: {a!r} != {b!r}"]
    except ValueError:
        return [path]


@pytest.mark.parametrize("robot_planner", ["social", "social+beta", "aggressive",
                                           "conservative", "cruise"])
def test_robot_policy_cannot_tell_the_pedestrian_variants_apart(robot_planner):
    """The robot's policy for `crossing`, `waiting` and `none` is the same object, state for
    state and action for action, given the same observations: nothing but its observation
    (not possible_agents, not the other agents' routes) tells it whether a pedestrian exists."""
    observations = _robot_observations()
    robots = []
    for variant in ("crossing", "waiting", "none"):
        env = marl_social.parallel_env(pedestrian=variant, robot_planner=robot_planner)
        robot = marl_social.policies(env)["robot_0"]
        robot.reset(0)
        robots.append(robot)
    assert _differences(robots[0], robots[1]) == [] and _differences(robots[0], robots[2]) == []
    for obs in observations:
        actions = [robot(obs) for robot in robots]
        np.testing.assert_array_equal(actions[0], actions[1])
        np.testing.assert_array_equal(actions[0], actions[2])
    assert _differences(robots[0], robots[1]) == []
    assert _differences(robots[0], robots[2]) == []
