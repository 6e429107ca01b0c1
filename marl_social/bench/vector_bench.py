"""Benchmark (never a timed unit test): vector_env throughput vs the same work in one env.

The single-agent autopilot env (`AutopilotGymEnv`: the robot is the user's, every other agent
runs its built-in planner) is stepped with seeded random robot actions. Both sides do the same
work, episode for episode: n copies, copy i seeded with seed + i, each making the same number
of steps with the same actions (a finished copy resets itself on its next step, as a vector
env does). The single rate runs the copies one after the other in one env in this process;
the vector rate runs them as a vector_env on 2 processes (this one and a child,
marl_social/envs/batched.py): 2 copies (one per process) and 16 copies (blocks of 8 per
process). Every rate counts env steps (one copy advancing one step = one step) per wall-clock
second, resets included, after a warm-up that pays each process's first-use costs.

Where the vector rate falls short of `workers` times the single one, the CPU the processes used
says why: time they spent idle, waiting for each other (the vector env's own), or steps that
take more CPU while two processes run at once than in one process alone (the machine's: shared
caches, memory bandwidth, or a virtual machine's cores that are threads of one physical core).

Why the same work: a copy's step costs more early in an episode (more agents alive), so a
short vector run of many copies against a long single-env run compares different work.
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import time
from pathlib import Path

import numpy as np

from marl_social.envs.vector import AutopilotGymEnv, vector_env

_WARM_UP_SEED = 10**6  # the warm-up episode's seed, apart from the timed ones


def random_actions(space, n_envs: int, n_steps: int, seed: int) -> np.ndarray:
    """(n_steps, n_envs, *space.shape) actions drawn uniformly in one copy's Box `space`."""
    rng = np.random.default_rng(seed)
    return rng.uniform(space.low, space.high,
                       (n_steps, n_envs, *space.shape)).astype(space.dtype)


def _warm_up(env: AutopilotGymEnv, actions: np.ndarray) -> None:
    """Pay this process's first-use costs: a few steps of an episode apart from the timed ones."""
    env.reset(seed=_WARM_UP_SEED)
    for k in range(3):
        env.step(actions[k, 0])


def _step_copies(env: AutopilotGymEnv, actions: np.ndarray, seed: int,
                 copies: range) -> np.ndarray:
    """(len(copies),) reward sums of `copies` run one after the other in `env`.

    Copy i: reset(seed=seed + i), then the steps of `actions[:, i]` (T, 2); a finished episode
    resets on the next step instead of stepping, as in a vector env.
    """
    reward_sums = np.zeros(len(copies))
    for k, i in enumerate(copies):
        env.reset(seed=seed + i)
        done = False
        for action in actions[:, i]:
            if done:
                env.reset()
                done = False
                continue
            _, reward, terminated, truncated, _ = env.step(action)
            reward_sums[k] += reward
            done = terminated or truncated
    return reward_sums


def process_cpu_s(pid: int) -> float | None:
    """CPU time (user + system) process `pid` has used so far [s]; None where /proc cannot tell.

    Read from /proc/<pid>/stat (Linux), in clock ticks (usually 10 ms).
    """
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def processes_cpu_s(pids=()) -> float | None:
    """CPU time used so far by this process and the processes `pids` [s]; None: one unknown."""
    others = [process_cpu_s(pid) for pid in pids]
    return None if None in others else time.process_time() + sum(others)


def single_env_steps_per_s(n_envs: int, n_steps: int, seed: int = 0, cpu: dict | None = None,
                           **env_kwargs) -> tuple[float, np.ndarray]:
    """(steps/s, (n_envs,) reward sums) of n_envs copies' work, one after the other in one env.

    Copy i: reset(seed=seed + i), then n_steps of `random_actions`' column i. A dict `cpu`
    gets "wall_s" and "cpu_s", the timed part's wall and CPU time [s].
    """
    env = AutopilotGymEnv(**env_kwargs)
    actions = random_actions(env.action_space, n_envs, n_steps, seed)
    _warm_up(env, actions)
    start, start_cpu = time.perf_counter(), processes_cpu_s()
    reward_sums = _step_copies(env, actions, seed, range(n_envs))
    seconds, cpu_s = time.perf_counter() - start, processes_cpu_s() - start_cpu
    env.close()
    if cpu is not None:
        cpu.update(wall_s=seconds, cpu_s=cpu_s)
    return n_envs * n_steps / seconds, reward_sums


def _independent_block(go, answers, actions, seed, copies, env_kwargs) -> None:
    """A child of `independent_steps_per_s`: warm up, say so, wait for `go`, step its copies.

    Answers ("ready", None, None), then (first copy, reward sums, end time [s]); on an error
    ("error", its text, None).
    """
    try:
        env = AutopilotGymEnv(**env_kwargs)
        _warm_up(env, actions)
        answers.put(("ready", None, None))
        go.wait()
        reward_sums = _step_copies(env, actions, seed, copies)
        answers.put((copies.start, reward_sums, time.perf_counter()))
        env.close()
    except Exception as error:  # noqa: BLE001 -- reported by the parent
        answers.put(("error", f"{type(error).__name__}: {error}", None))


def _answer(answers, timeout_s: float = 600.0) -> tuple:
    """The next answer of an `_independent_block` child; RuntimeError on its error or silence."""
    try:
        answer = answers.get(timeout=timeout_s)
    except queue.Empty:
        raise RuntimeError(f"bench vector: a process stepping copies gave no answer in "
                           f"{timeout_s:.0f} s") from None
    if answer[0] == "error":
        raise RuntimeError(f"bench vector: a process stepping copies failed: {answer[1]}")
    return answer


def independent_steps_per_s(n_envs: int, n_steps: int, seed: int = 0, workers: int = 2,
                            **env_kwargs) -> tuple[float, np.ndarray]:
    """(steps/s, (n_envs,) reward sums) of the same work on processes that never wait.

    Each of the `workers` processes runs its block of copies alone, start to end: the most any
    vector env of `workers` processes could reach on this machine; what is left between it and
    vector_env is the vector env's own (every vector step waits for the slower block). Wall
    time runs from the common start, once every process has warmed up, until the last is done.
    """
    probe = AutopilotGymEnv(**env_kwargs)  # the action space (and bad arguments fail here)
    actions = random_actions(probe.action_space, n_envs, n_steps, seed)
    probe.close()
    context = multiprocessing.get_context("fork")
    go, answers = context.Event(), context.Queue()
    bounds = [(w * n_envs) // workers for w in range(workers + 1)]
    processes = [context.Process(target=_independent_block, daemon=True,
                                 args=(go, answers, actions, seed,
                                       range(bounds[w], bounds[w + 1]), env_kwargs))
                 for w in range(workers)]
    for process in processes:
        process.start()
    try:
        for _ in processes:
            _answer(answers)  # "ready": warmed up
        start = time.perf_counter()
        go.set()
        reward_sums, end = np.zeros(n_envs), start
        for _ in processes:
            first, sums, finished = _answer(answers)
            reward_sums[first:first + len(sums)] = sums
            end = max(end, finished)
    finally:
        for process in processes:
            process.join(timeout=10.0)
            if process.is_alive():
                process.terminate()
    return n_envs * n_steps / (end - start), reward_sums


def vector_env_steps_per_s(n_envs: int, n_steps: int, seed: int = 0, workers: int | None = None,
                           cpu: dict | None = None, **env_kwargs) -> tuple[float, np.ndarray]:
    """(steps/s, (n_envs,) reward sums) of `single_env_steps_per_s`' work in a vector_env.

    workers None: vector_env's default. A dict `cpu` gets "wall_s", the timed part's wall
    time, and "cpu_s", the CPU time every process of the vector env used in it [s] (this one's
    and its workers'; None where /proc cannot tell a worker's).
    """
    venv = vector_env(n_envs, workers=workers, **env_kwargs)
    try:
        actions = random_actions(venv.single_action_space, n_envs, n_steps, seed)
        venv.reset(seed=_WARM_UP_SEED)
        for k in range(3):  # warm-up: every process's first-use costs
            venv.step(actions[k])
        reward_sums = np.zeros(n_envs)
        pids = getattr(venv, "worker_pids", ())
        start, start_cpu = time.perf_counter(), processes_cpu_s(pids)
        venv.reset(seed=seed)
        for t in range(n_steps):
            _, rewards, _, _, _ = venv.step(actions[t])  # finished copies reset themselves
            reward_sums += rewards
        seconds, end_cpu = time.perf_counter() - start, processes_cpu_s(pids)
    finally:
        venv.close()
    if cpu is not None:
        known = start_cpu is not None and end_cpu is not None
        cpu.update(wall_s=seconds, cpu_s=end_cpu - start_cpu if known else None)
    return n_envs * n_steps / seconds, reward_sums


def bench_vector(n_envs: int = 16, workers: int = 2, n_steps: int = 150, rounds: int = 3,
                 echo=print, **env_kwargs) -> dict:
    """vector_env vs the same work in one env, on the paper scenario (or env_kwargs).

    vector_env(workers) (a copy per process) and vector_env(n_envs, workers=workers) (blocks
    of copies per process), both on `workers` processes, every copy making n_steps steps. The
    one-env and vector runs alternate for `rounds` rounds and each speed-up is the median of
    the rounds' ratios: a shared machine's speed drifts by ~10-20 % between runs, and a ratio of
    two runs made back to back drifts less than either rate.

    Returns:
        {"single_steps_per_s", "vector_steps_per_s", "n_envs", "workers", "speedup",
        "one_per_process_steps_per_s", "one_per_process_speedup", "same_episodes",
        "speedups", "one_per_process_speedups", "independent_speedup",
        "independent_speedups"} (rates and speed-ups: medians over the rounds; the lists: every
        round's ratio; independent: `independent_steps_per_s`, the machine's ceiling).
    """
    env_kwargs.setdefault("scenario", "occluded_crosswalk")
    runs = {key: [] for key in ("pair_single", "pair_vector", "single", "vector",
                                "independent")}
    busy, cpu_ratios = [], []  # per round: the vector env's busy share, its CPU per step / one env's
    same = True
    for _ in range(rounds):
        pair_single, pair_single_rewards = single_env_steps_per_s(workers, n_steps, **env_kwargs)
        pair_vector, pair_vector_rewards = vector_env_steps_per_s(workers, n_steps,
                                                                  workers=workers, **env_kwargs)
        single_cpu, vector_cpu = {}, {}
        single, single_rewards = single_env_steps_per_s(n_envs, n_steps, cpu=single_cpu,
                                                        **env_kwargs)
        vector, vector_rewards = vector_env_steps_per_s(n_envs, n_steps, workers=workers,
                                                        cpu=vector_cpu, **env_kwargs)
        if vector_cpu["cpu_s"] is not None:
            busy.append(vector_cpu["cpu_s"] / (workers * vector_cpu["wall_s"]))
            cpu_ratios.append(vector_cpu["cpu_s"] / single_cpu["cpu_s"])
        independent, independent_rewards = independent_steps_per_s(n_envs, n_steps,
                                                                   workers=workers, **env_kwargs)
        same &= bool(np.array_equal(single_rewards, vector_rewards)
                     and np.array_equal(single_rewards, independent_rewards)
                     and np.array_equal(pair_single_rewards, pair_vector_rewards))
        for key, rate in zip(runs, (pair_single, pair_vector, single, vector, independent)):
            runs[key].append(rate)
    rates = {key: np.asarray(values) for key, values in runs.items()}
    speedups = rates["vector"] / rates["single"]
    pair_speedups = rates["pair_vector"] / rates["pair_single"]
    ceilings = rates["independent"] / rates["single"]
    row = {"configuration": f"vector_env({n_envs}, workers={workers}) {env_kwargs['scenario']}",
           "n_envs": n_envs, "workers": workers,
           "single_steps_per_s": float(np.median(rates["single"])),
           "vector_steps_per_s": float(np.median(rates["vector"])),
           "speedup": float(np.median(speedups)), "speedups": speedups.tolist(),
           "one_per_process_steps_per_s": float(np.median(rates["pair_vector"])),
           "one_per_process_speedup": float(np.median(pair_speedups)),
           "one_per_process_speedups": pair_speedups.tolist(), "same_episodes": same,
           "independent_speedup": float(np.median(ceilings)),
           "independent_speedups": ceilings.tolist(),
           "vector_busy_shares": busy, "vector_cpu_per_step_ratios": cpu_ratios}
    echo(f"autopilot env ({env_kwargs['scenario']}, robot random, others on their planners; "
         f"{n_steps} steps per copy, the same episodes in one env and on {workers} processes"
         f"{'' if same else ' -- REWARDS DIFFER'}; median of {rounds} rounds):")
    echo(f"  vector_env({workers}) {row['one_per_process_steps_per_s']:.1f} steps/s = "
         f"{row['one_per_process_speedup']:.2f}x one env (rounds "
         f"{', '.join(f'{r:.2f}' for r in pair_speedups)})")
    echo(f"  vector_env({n_envs}) {row['vector_steps_per_s']:.1f} steps/s = "
         f"{row['speedup']:.2f}x one env's {row['single_steps_per_s']:.1f} (rounds "
         f"{', '.join(f'{r:.2f}' for r in speedups)})")
    echo(f"  the machine's ceiling, the same {n_envs} copies on {workers} processes that never "
         f"wait for each other: {row['independent_speedup']:.2f}x (rounds "
         f"{', '.join(f'{r:.2f}' for r in ceilings)}); vector_env({n_envs}) reaches "
         f"{100 * np.median(speedups / ceilings):.0f} % of it")
    if busy:
        echo(f"  why not {workers}x: vector_env({n_envs})'s {workers} processes were busy "
             f"{100 * np.median(busy):.0f} % of its wall time (the rest waiting for each other; "
             f"rounds {', '.join(f'{100 * b:.0f}' for b in busy)} %), and an env step took "
             f"{np.median(cpu_ratios):.2f}x the CPU it takes one env alone (the machine running "
             f"{workers} processes at once; rounds {', '.join(f'{r:.2f}' for r in cpu_ratios)})")
    return row
