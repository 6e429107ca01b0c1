"""Env copies batched over a few processes: fewer processes than copies.

    venv = BatchedVectorEnv(8, 2, functools.partial(AutopilotGymEnv, ["robot_0"]))

`marl_social.vector_env` builds one for autopilot envs (marl_social/envs/vector.py).

Gymnasium's AsyncVectorEnv runs one process per copy, and every vector step waits for the
slowest copy. An autopilot step's cost varies with what its planners face (on the paper scenario
the slower of two copies takes ~1.2 times a mean step), so two copies on two cores cannot reach
twice one copy's rate. Here each worker process steps a contiguous block of copies one after the
other and answers with the whole block in one message: a block's total varies relatively less
than one copy's step, so the wait for the slower worker shrinks, and there is one round trip per
worker instead of per copy. This process is the first worker (`in_process`): it steps its own
block while the child processes step theirs, so on 2 cores two workers keep both cores busy with
env steps, and no third process waits for them.

Each copy behaves exactly as in Gymnasium's SyncVectorEnv (next-step autoreset, `reset(seed=s)`
seeds copy i with s + i, infos merged with the same `_add_info`), so a batched, an asynchronous
and an in-process vector env give bit-identical episodes (tests/envs/test_vector.py).
"""

from __future__ import annotations

import copy
import multiprocessing
import traceback

import numpy as np
from gymnasium.vector import VectorEnv
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array, iterate

from marl_social.sim.seeds import checked_seed


class _Block:
    """A block of env copies and what a command does to them (in a worker or this process)."""

    def __init__(self, env_fn, n_copies: int):
        """Build the copies (if one fails, those already built are closed)."""
        self.envs = []
        try:
            for _ in range(n_copies):
                self.envs.append(env_fn())
        except BaseException:
            self.close()
            raise
        self.done = np.zeros(n_copies, dtype=bool)

    def answer(self, command: str, data):
        """The block's answer to one command (raises what a copy raises)."""
        envs, done = self.envs, self.done
        if command == "reset":
            seeds, options = data
            out = [env.reset(seed=s, options=options) for env, s in zip(envs, seeds)]
            done[:] = False
            return out
        if command == "step":
            out = []
            for i, (env, action) in enumerate(zip(envs, data)):
                if done[i]:  # next-step autoreset, as SyncVectorEnv
                    obs, info = env.reset()
                    out.append((obs, 0.0, False, False, info))
                    done[i] = False
                else:
                    obs, reward, term, trunc, info = env.step(action)
                    out.append((obs, reward, term, trunc, info))
                    done[i] = term or trunc
            return out
        if command == "call":
            name, args, kwargs = data
            results = []
            for env in envs:
                attr = getattr(env, name)
                results.append(attr(*args, **kwargs) if callable(attr) else attr)
            return results
        if command == "close":
            return None
        raise ValueError(f"batched vector env: unknown command {command!r}")

    def close(self) -> None:
        """Close the copies."""
        for env in self.envs:
            env.close()


def _worker(pipe, parent_pipe, env_fn, n_copies: int) -> None:
    """Run a block of env copies in a worker process; answer (ok, payload) to each command."""
    parent_pipe.close()
    block = None
    try:
        block = _Block(env_fn, n_copies)
        while True:
            command, data = pipe.recv()
            try:
                pipe.send((True, block.answer(command, data)))
            except Exception:  # noqa: BLE001 -- reported to the main process, which raises
                pipe.send((False, traceback.format_exc()))
            if command == "close":
                return
    except Exception:  # noqa: BLE001 -- building the copies failed
        pipe.send((False, traceback.format_exc()))
    finally:
        if block is not None:
            block.close()
        pipe.close()


class BatchedVectorEnv(VectorEnv):
    """n Gymnasium env copies stepped by `workers` processes, each a contiguous block.

    Args:
        n: number of copies.
        workers: processes that step copies (1 <= workers <= n); process w steps copies
            w * n // workers up to (w + 1) * n // workers.
        env_fn: a picklable callable that builds one copy (e.g. a functools.partial of an
            env class).
        context: multiprocessing start method ("fork", "spawn", "forkserver"); None for the
            platform default.
        in_process: True: this process is worker 0 -- it steps the first block while the
            workers - 1 child processes step theirs (on 2 cores, 2 workers use both cores
            without a third process waiting on them, and the first block's observations
            cross no pipe); False: every block in a child process.
    """

    def __init__(self, n: int, workers: int, env_fn, context=None, in_process: bool = True):
        """Start the workers; the spaces are those of one copy built in this process."""
        self._local, self._pipes, self._processes = None, [], []
        if not 1 <= workers <= n:
            raise ValueError(f"batched vector env: need 1 <= workers <= n, got workers={workers}"
                             f", n={n}")
        probe = env_fn()  # bad arguments fail here, not in a worker
        self.num_envs = int(n)
        self.single_observation_space = probe.observation_space
        self.single_action_space = probe.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.metadata = dict(probe.metadata)
        self.metadata["autoreset_mode"] = "NextStep"
        self.render_mode = probe.render_mode
        probe.close()
        bounds = [(w * n) // workers for w in range(workers + 1)]
        self._blocks = [range(bounds[w], bounds[w + 1]) for w in range(workers)]
        self._observations = create_empty_array(self.single_observation_space, self.num_envs)
        self.closed = False
        self._local = _Block(env_fn, len(self._blocks[0])) if in_process else None
        ctx = multiprocessing.get_context(context)
        for block in self._blocks[1 if in_process else 0:]:
            parent, child = ctx.Pipe()
            process = ctx.Process(target=_worker, daemon=True,
                                  args=(child, parent, env_fn, len(block)))
            process.start()
            child.close()
            self._pipes.append(parent)
            self._processes.append(process)

    @property
    def worker_pids(self) -> tuple[int, ...]:
        """The pids of the child processes that step the blocks after this process's own."""
        return tuple(process.pid for process in self._processes)

    def _answers(self, messages):
        """Send one message to every block, then yield their answers in block order.

        The child processes get theirs first; this process then answers for its own block
        (in_process) while they work, and the caller handles each answer while the later
        workers are still busy. If a block failed, every answer is read (the pipes stay in
        step) and a RuntimeError raised.
        """
        if self._local is not None:
            (command, data), messages = messages[0], messages[1:]
        for w, (pipe, message) in enumerate(zip(self._pipes, messages)):
            try:
                pipe.send(message)
            except OSError:  # BrokenPipeError: the worker has died
                raise self._died(w) from None
        if self._local is not None:
            try:
                local = self._local.answer(command, data)
            except Exception:  # noqa: BLE001 -- raised below, once the pipes are read
                for w in range(len(self._pipes)):
                    self._receive(w)
                raise RuntimeError("batched vector env: a copy in this process failed:\n"
                                   + traceback.format_exc()) from None
            yield local
        for w in range(len(self._pipes)):
            ok, payload = self._receive(w)
            if not ok:
                for later in range(w + 1, len(self._pipes)):
                    self._receive(later)
                raise RuntimeError(f"batched vector env: a worker failed:\n{payload}")
            yield payload

    def _receive(self, w: int) -> tuple:
        """The answer (ok, payload) of child process w (`_died` if it has died)."""
        try:
            return self._pipes[w].recv()
        except (EOFError, OSError):
            raise self._died(w) from None

    def _died(self, w: int) -> RuntimeError:
        """The error for child process w found dead (its pipe closed).

        A worker killed from outside (the OOM killer, a signal) or one that could not start
        (e.g. the "spawn" context re-running a script without an ``if __name__ ==
        "__main__":`` guard) closes its pipe: the error names it and its exit code, rather
        than a bare EOFError or BrokenPipeError from deep inside multiprocessing.
        """
        process = self._processes[w]
        process.join(timeout=1.0)
        return RuntimeError(
            f"batched vector env: worker process {w + 1} of {len(self._pipes)} (pid "
            f"{process.pid}) died (exit code {process.exitcode}); the vector env cannot go "
            f"on: close it and build a new one. With the 'spawn' or 'forkserver' context, "
            f"the script that builds it needs an `if __name__ == \"__main__\":` guard")

    def _ask(self, messages) -> list:
        """Send one message to every block; their answers in block order."""
        return list(self._answers(messages))

    def reset(self, *, seed=None, options=None):
        """Reset every copy; seed s seeds copy i with s + i (a list: one seed per copy)."""
        if seed is None:
            seed = [None] * self.num_envs
        elif isinstance(seed, (int, np.integer)):
            first = checked_seed(seed)
            seed = [checked_seed(first + i, "seed + copy index") for i in range(self.num_envs)]
        else:
            seed = [checked_seed(s, "seed of a copy") for s in seed]
        if len(seed) != self.num_envs:
            raise ValueError(f"batched vector env: {len(seed)} seeds for {self.num_envs} copies")
        answers = self._ask([("reset", ([seed[i] for i in block], options))
                             for block in self._blocks])
        results = [r for answer in answers for r in answer]
        infos = {}
        for i, (_, info) in enumerate(results):
            infos = self._add_info(infos, info, i)
        self._observations = concatenate(self.single_observation_space,
                                         [obs for obs, _ in results], self._observations)
        return copy.deepcopy(self._observations), infos

    def step(self, actions):
        """Step every copy (a finished copy resets itself on its next step)."""
        per_copy = list(iterate(self.action_space, actions))
        answers = self._answers([("step", [per_copy[i] for i in block])
                                 for block in self._blocks])
        observations, infos = [], {}
        rewards = np.zeros(self.num_envs, dtype=np.float64)
        terminations = np.zeros(self.num_envs, dtype=np.bool_)
        truncations = np.zeros(self.num_envs, dtype=np.bool_)
        for block, answer in zip(self._blocks, answers):  # while the later workers still step
            for i, (obs, reward, term, trunc, info) in zip(block, answer):
                observations.append(obs)
                rewards[i], terminations[i], truncations[i] = reward, term, trunc
                infos = self._add_info(infos, info, i)
        self._observations = concatenate(self.single_observation_space, observations,
                                         self._observations)
        return copy.deepcopy(self._observations), rewards, terminations, truncations, infos

    def call(self, name: str, *args, **kwargs) -> tuple:
        """Call a method (or read an attribute) of every copy; results in copy order."""
        answers = self._ask([("call", (name, args, kwargs))] * len(self._blocks))
        return tuple(r for answer in answers for r in answer)

    def render(self):
        """Every copy's frame (render_mode "rgb_array")."""
        return self.call("render")

    def close_extras(self, **kwargs) -> None:
        """Stop the workers and close this process's copies."""
        if self._local is not None:
            self._local.close()
        for pipe, process in zip(self._pipes, self._processes):
            try:
                if process.is_alive():
                    pipe.send(("close", None))
                    pipe.recv()
            except (BrokenPipeError, EOFError, OSError):
                pass
            pipe.close()
            process.join(timeout=5)
            if process.is_alive():
                process.terminate()
