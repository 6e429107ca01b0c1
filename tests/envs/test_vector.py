"""vector_env: n autopilot envs in worker processes behave exactly like n single envs."""

from __future__ import annotations

import os
import signal
import time

import numpy as np
import pytest

import marl_social
from marl_social.envs.vector import AutopilotGymEnv

MAX_CYCLES = 8  # short episodes: the rollouts below cross autoresets


def _rollout(env, seed: int, steps: int, n: int | None = None):
    """(observations, rewards, terminated, truncated) of a seeded random-action rollout."""
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    space = env.single_action_space if n else env.action_space
    low, high = space.low, space.high
    out = [(np.array(obs, copy=True), None, None, None)]
    for _ in range(steps):
        action = rng.uniform(low, high, (n, 2) if n else 2) * 0.5
        obs, reward, term, trunc, _ = env.step(action)
        out.append((np.array(obs, copy=True), np.array(reward), np.array(term), np.array(trunc)))
    return out


def _same(a, b) -> bool:
    return all(all(np.array_equal(x, y) for x, y in zip(ra, rb)) for ra, rb in zip(a, b))


def test_worker_processes_give_the_same_episodes_as_one_process_and_repeat_per_seed():
    seed = int(np.random.default_rng().integers(1000))
    kwargs = {"scenario": "occluded_crosswalk", "max_cycles": MAX_CYCLES}
    venv = marl_social.vector_env(2, **kwargs)
    try:
        first = _rollout(venv, seed, 2 * MAX_CYCLES + 3, n=2)
        again = _rollout(venv, seed, 2 * MAX_CYCLES + 3, n=2)
    finally:
        venv.close()
    sync = marl_social.vector_env(2, asynchronous=False, **kwargs)
    in_process = _rollout(sync, seed, 2 * MAX_CYCLES + 3, n=2)
    assert _same(first, again)
    assert _same(first, in_process)
    assert first[1][0].shape == (2, venv.single_observation_space.shape[0])
    assert not np.array_equal(first[1][0][0], first[1][0][1])  # the copies differ


def test_each_copy_is_the_single_env_seeded_with_seed_plus_its_index():
    seed = int(np.random.default_rng().integers(1000))
    kwargs = {"scenario": "occluded_crosswalk", "max_cycles": MAX_CYCLES}
    venv = marl_social.vector_env(2, asynchronous=False, **kwargs)
    obs, _ = venv.reset(seed=seed)
    single = AutopilotGymEnv(["robot_0"], **kwargs)
    for i in range(2):
        own, _ = single.reset(seed=seed + i)
        assert np.array_equal(obs[i], own)
    # a copy's actions reach its own env: same actions, same next observation
    action = np.array([[0.5, 0.0], [-1.0, 0.01]])
    obs, reward, *_ = venv.step(action)
    own, own_reward, *_ = single.step(action[1])
    assert np.array_equal(obs[1], own)
    assert reward[1] == own_reward


def test_episodes_end_by_truncation_at_max_cycles_and_the_copy_resets_itself():
    venv = marl_social.vector_env(2, asynchronous=False, scenario="long_road", n_vehicles=3,
                                  max_cycles=MAX_CYCLES)
    obs0, _ = venv.reset(seed=5)
    zero = np.zeros((2, 2))
    for step in range(1, MAX_CYCLES + 1):
        _, _, term, trunc, _ = venv.step(zero + [0.0, 0.0])
        if term.any():
            pytest.skip("a copy collided before max_cycles")  # not this test's claim
        assert trunc.all() == (step == MAX_CYCLES)
    obs, reward, term, trunc, _ = venv.step(zero)  # next-step autoreset: a fresh episode
    assert not trunc.any() and not term.any()
    assert np.all(reward == 0.0)
    assert not np.array_equal(obs, obs0)  # the next episode draws a new seed


def test_several_controlled_agents_get_dict_spaces_and_summed_rewards():
    env = AutopilotGymEnv(["robot_0", "human_0"], scenario="occluded_crosswalk",
                          max_cycles=MAX_CYCLES)
    obs, info = env.reset(seed=2)
    assert set(obs) == {"robot_0", "human_0"} == set(info)
    pz = marl_social.autopilot(marl_social.parallel_env(scenario="occluded_crosswalk",
                                                        max_cycles=MAX_CYCLES),
                               controlled=["robot_0", "human_0"])
    pz_obs, _ = pz.reset(seed=env._last_episode_seed)
    assert all(np.array_equal(obs[a], pz_obs[a]) for a in obs)
    actions = {"robot_0": np.array([0.3, 0.0]), "human_0": np.array([-0.2, 0.0])}
    _, reward, *_ = env.step(actions)
    _, pz_rewards, *_ = pz.step(actions)
    assert reward == pytest.approx(sum(pz_rewards.values()), rel=0, abs=1e-12)
    with pytest.raises(ValueError, match="human_0"):
        env.step({"robot_0": np.zeros(2)})


@pytest.mark.parametrize("bad", [0, -1, 1.5, True])
def test_bad_copy_count_is_a_value_error(bad):
    with pytest.raises(ValueError, match="n must be a positive integer"):
        marl_social.vector_env(bad)


def test_unknown_controlled_agent_is_named_before_any_worker_starts():
    with pytest.raises(ValueError, match="robot_7"):
        marl_social.vector_env(2, controlled=["robot_7"])


def _rollout_with_infos(env, seed: int, steps: int, n: int):
    obs, info = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    low, high = env.single_action_space.low, env.single_action_space.high
    out = [(np.array(obs, copy=True), repr(info))]
    for _ in range(steps):
        obs, reward, term, trunc, info = env.step(rng.uniform(low, high, (n, 2)) * 0.5)
        out.append((np.array(obs, copy=True), reward.tobytes(), term.tobytes(), trunc.tobytes(),
                    repr(info)))
    return out


def test_copies_batched_on_fewer_workers_give_the_same_episodes_and_infos():
    """3 copies on 2 workers (blocks of 1 and 2) = 3 copies in one process, infos included."""
    seed = int(np.random.default_rng().integers(1000))
    kwargs = {"scenario": "occluded_crosswalk", "max_cycles": MAX_CYCLES}
    venv = marl_social.vector_env(3, workers=2, **kwargs)
    try:
        assert type(venv).__name__ == "BatchedVectorEnv"
        batched = _rollout_with_infos(venv, seed, 2 * MAX_CYCLES + 3, 3)
        batched_again = _rollout_with_infos(venv, seed, 2 * MAX_CYCLES + 3, 3)
    finally:
        venv.close()
    sync = marl_social.vector_env(3, asynchronous=False, **kwargs)
    in_process = _rollout_with_infos(sync, seed, 2 * MAX_CYCLES + 3, 3)
    for a, b, c in zip(batched, batched_again, in_process):
        assert all(np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y
                   for x, y in zip(a, b))
        assert all(np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y
                   for x, y in zip(a, c))


def test_every_block_in_a_child_process_gives_the_same_episodes():
    """in_process=False (no block in this process) = the default (the first block here)."""
    import functools

    from marl_social.envs.batched import BatchedVectorEnv

    seed = int(np.random.default_rng().integers(1000))
    kwargs = {"scenario": "occluded_crosswalk", "max_cycles": MAX_CYCLES}
    make = functools.partial(AutopilotGymEnv, ["robot_0"], **kwargs)
    runs = []
    for in_process in (True, False):
        venv = BatchedVectorEnv(3, 2, make, in_process=in_process)
        try:
            assert len(venv.worker_pids) == (1 if in_process else 2)
            runs.append(_rollout_with_infos(venv, seed, MAX_CYCLES + 3, 3))
        finally:
            venv.close()
    for a, b in zip(*runs):
        assert all(np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y
                   for x, y in zip(a, b))


def test_a_failing_call_in_this_process_is_one_error_and_the_copies_step_on():
    kwargs = {"scenario": "occluded_crosswalk", "max_cycles": MAX_CYCLES}
    venv = marl_social.vector_env(3, workers=2, **kwargs)
    try:
        venv.reset(seed=3)
        with pytest.raises(RuntimeError, match="(?s)in this process failed.*no_such_method"):
            venv.call("no_such_method")
        obs, reward, *_ = venv.step(np.zeros((3, 2)))  # every pipe is still in step
        assert obs.shape[0] == 3 and reward.shape == (3,)
    finally:
        venv.close()


def test_workers_are_checked():
    with pytest.raises(ValueError, match="workers"):
        marl_social.vector_env(2, workers=3, scenario="occluded_crosswalk")
    with pytest.raises(ValueError, match="workers"):
        marl_social.vector_env(2, workers=0, scenario="occluded_crosswalk")


@pytest.mark.skipif(not hasattr(os, "sched_getaffinity"), reason="needs an affinity mask")
def test_the_default_workers_are_the_cores_this_process_may_use(monkeypatch):
    """Pinned to one core of many (a container's cpuset, taskset), a vector env steps its
    copies in this process alone: lock-step processes sharing a core only wait for each other."""
    from marl_social.envs.vector import usable_cores

    assert usable_cores() == len(os.sched_getaffinity(0))
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0})
    monkeypatch.setattr(os, "cpu_count", lambda: 64)
    assert usable_cores() == 1
    venv = marl_social.vector_env(3, max_cycles=5)
    try:
        assert venv.worker_pids == ()
        venv.reset(seed=0)
    finally:
        venv.close()


def test_a_killed_worker_is_a_clear_error_naming_it_and_close_still_works():
    """A worker killed from outside (OOM killer, a signal) is named, with its exit code."""
    venv = marl_social.vector_env(2, workers=2, scenario="occluded_crosswalk",
                                  max_cycles=MAX_CYCLES)
    try:
        venv.reset(seed=0)
        worker = venv._processes[0]
        assert venv.worker_pids == (worker.pid,)
        os.kill(worker.pid, signal.SIGKILL)
        worker.join(timeout=10)
        with pytest.raises(RuntimeError) as err:
            venv.step(np.zeros((2, 2)))
        message = str(err.value)
        assert f"worker process 1 of 1 (pid {worker.pid}) died" in message
        assert f"exit code {-signal.SIGKILL}" in message and "build a new one" in message
        assert "Traceback" not in message
    finally:
        venv.close()
    assert venv.closed


@pytest.mark.slow
def test_the_vector_bench_sets_the_same_episodes_side_by_side():
    """`marl-social bench env`'s vector row: one env running the copies one after the other,
    the vector env and the processes that never wait earn the same rewards, copy by copy."""
    from marl_social.bench.vector_bench import (
        independent_steps_per_s,
        single_env_steps_per_s,
        vector_env_steps_per_s,
    )

    kwargs = {"scenario": "occluded_crosswalk", "max_cycles": 12}  # episodes end and reset
    one_cpu, vector_cpu = {}, {}
    _, one_env = single_env_steps_per_s(3, 30, seed=5, cpu=one_cpu, **kwargs)
    _, vector = vector_env_steps_per_s(3, 30, seed=5, workers=2, cpu=vector_cpu, **kwargs)
    _, apart = independent_steps_per_s(3, 30, seed=5, workers=2, **kwargs)
    assert np.array_equal(one_env, vector) and np.array_equal(one_env, apart)
    assert len(set(one_env.tolist())) == 3  # the copies' episodes differ
    # the CPU it reports is both processes': the worker's too (at most 2 cores' worth, give or
    # take /proc's 10 ms ticks), and the one env's is its own process's
    assert 0.0 < one_cpu["cpu_s"] <= one_cpu["wall_s"] + 0.02
    assert 0.0 < vector_cpu["cpu_s"] <= 2 * vector_cpu["wall_s"] + 0.04
    # the same work as the one env: this process steps 1 of the 3 copies, so without the
    # worker's CPU the sum would be about a third of the one env's (measured 1.1-1.4x with it)
    assert vector_cpu["cpu_s"] >= 0.6 * one_cpu["cpu_s"]


def test_process_cpu_is_that_of_the_named_process():
    """The bench's CPU time of another process (/proc) grows with the work it does."""
    import subprocess
    import sys

    from marl_social.bench.vector_bench import process_cpu_s

    if process_cpu_s(os.getpid()) is None:
        pytest.skip("needs Linux /proc")
    start = time.monotonic()
    code = "import time\nt = time.process_time()\nwhile time.process_time() - t < 0.3: pass\ninput()"
    busy = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE)
    try:
        while (process_cpu_s(busy.pid) or 0.0) < 0.3 and time.monotonic() < start + 30:
            time.sleep(0.05)
        assert 0.3 <= process_cpu_s(busy.pid) <= time.monotonic() - start + 0.02
    finally:
        busy.communicate(b"\n", timeout=30)
    assert process_cpu_s(busy.pid) is None  # gone
