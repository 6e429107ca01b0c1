"""The Ray backend of studies: one remote task per run on a Ray cluster.

Where the tasks run (`address`, the CLI's `--address`):

* None (default): a private local Ray instance (`ray.init(address="local")`) with `workers`
  CPUs, shut down when the study ends. It never attaches to another cluster on the machine,
  nor follows a stale `/tmp/ray/ray_current_cluster` file.
* "HOST:PORT": the cluster whose head was started with `ray start --head --port PORT`.
* "auto": the cluster started with `ray start` on this machine (Ray's own lookup).
* "ray://HOST:10001": the same cluster through Ray Client.

If this process is already connected (`ray.is_initialized()`), that connection is used and kept.
Every node needs marl-social installed (the same version); docs/ray.md has the recipe.

Token authentication (Ray 2.60, installed here): `ray start --head` enables it when a token
exists (`~/.ray/auth_token`, or RAY_AUTH_TOKEN / RAY_AUTH_TOKEN_PATH) or RAY_AUTH_MODE=token;
`ray.init()` of a new local instance enables it and creates ~/.ray/auth_token. A client that
connects to an explicit address uses a token only with RAY_AUTH_MODE=token set, so the study
process then needs RAY_AUTH_MODE=token and the head's token (RAY_AUTH_TOKEN=`ray
get-auth-token` of the head). A connection that fails raises `RayConnectionError`, one line
naming the address and the fix (the CLI prints it without a traceback).

Every task first checks that its worker imports the same marl-social sources as the study
process (`jobs.code_fingerprint`); a worker with other code (e.g. a node started with another
Python environment, whose `ray` runs an older install) stops the study with a
`RayConnectionError` instead of mixing results of two code versions.

Stopping: at most 2 tasks per cluster CPU are in flight. When the study ends early (an exception,
Ctrl-C, or SIGTERM, which ends the study with exit code 143 while its tasks run), on a cluster
every task still running is cancelled (`ray.cancel(force=True)`: its worker process is killed)
before the process disconnects, so no run keeps a cluster CPU busy after its study is gone. A
private local instance is not cancelled task by task: `ray.shutdown()` stops it with its workers.
(Ray 2.60's core worker aborts the whole process, exit code 1, when a cancel meets the reply of
a task finishing at that moment, `Check failed: ... Tried to complete task that was not pending`;
the finished tasks are therefore left out of the cancel, and the private instance needs none.)
"""

from __future__ import annotations

import contextlib
import itertools
import os
import signal
import socket
import threading
from collections.abc import Iterator

from marl_social.studies.jobs import code_fingerprint, error_text, run_job

CONNECT_PROBE_S = 5.0  # timeout of the TCP probe of an explicit HOST:PORT address [s]
GCS_CONNECT_TRIES = "3"  # Ray's GCS connection attempts (~1 s each) for an explicit address
AUTH_FIX = ("export RAY_AUTH_MODE=token RAY_AUTH_TOKEN=<the head's token: `ray get-auth-token` "
            "on the head> (or RAY_AUTH_TOKEN_PATH=<a file holding it>)")
SIGTERM_EXIT_CODE = 128 + int(signal.SIGTERM)


class RayConnectionError(RuntimeError):
    """The study could not connect to the Ray cluster: the message names the address and fix."""


def import_ray():
    try:
        import ray
    except ImportError as err:
        raise ImportError("the Ray backend needs Ray: pip install marl-social[ray]") from err
    return ray


def _host_port(address: str) -> tuple[str, int] | None:
    """(host, port) of an explicit "HOST:PORT" GCS address, None for auto, local or ray://."""
    if "://" in address or address in ("auto", "local"):
        return None
    host, sep, port = address.rpartition(":")
    if not sep or not port.isdigit():
        raise RayConnectionError(f"--address {address!r}: expected HOST:PORT of a Ray head "
                                 "(`ray start --head --port PORT`), auto or ray://HOST:PORT")
    return host.strip("[]") or "127.0.0.1", int(port)


def _probe(address: str) -> None:
    """Fail fast, in one line, if nothing listens at an explicit HOST:PORT address."""
    target = _host_port(address)
    if target is None:
        return
    try:
        socket.create_connection(target, timeout=CONNECT_PROBE_S).close()
    except OSError as err:
        reason = err.strerror or type(err).__name__
        raise RayConnectionError(
            f"cannot reach the Ray cluster at {address} ({reason}): start its head with "
            f"`ray start --head --port {target[1]}` or pass the head's HOST:PORT to --address "
            "(docs/ray.md)") from None


def _chain_text(err: BaseException) -> str:
    """The messages of an exception and of its causes, joined."""
    texts, seen = [], set()
    while err is not None and id(err) not in seen:
        seen.add(id(err))
        texts.append(f"{type(err).__name__}: {err}")
        err = err.__cause__ or err.__context__
    return " | ".join(texts)


def _connection_error(address: str, err: BaseException) -> RayConnectionError:
    """A one-line error with its fix for a failed `ray.init(address=...)`."""
    text = _chain_text(err)
    if "InvalidAuthToken" in text or "AuthenticationError" in text or "authentication" in text:
        if os.environ.get("RAY_AUTH_MODE", "").lower() != "token":
            return RayConnectionError(f"the Ray cluster at {address} requires token "
                                      f"authentication: {AUTH_FIX} (docs/ray.md)")
        return RayConnectionError(f"the Ray cluster at {address} rejected this process's token "
                                  f"(or none was found): {AUTH_FIX} (docs/ray.md)")
    first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
    return RayConnectionError(f"cannot connect to the Ray cluster at {address}: {first[:200]}; "
                              f"check `ray status --address {address}` (docs/ray.md)")


@contextlib.contextmanager
def _env(name: str, default: str) -> Iterator[None]:
    """Set an environment variable to default unless the user set it; restore it afterwards."""
    if name in os.environ:
        yield
        return
    os.environ[name] = default
    try:
        yield
    finally:
        os.environ.pop(name, None)


def connect(ray, address: str | None, workers: int) -> bool:
    """Connect to (or start) Ray; True if this call connected (and must disconnect).

    Args:
        ray: the ray module.
        address: see the module docstring; None starts a private local instance.
        workers: CPUs of a private local instance.

    Raises:
        RayConnectionError: the cluster at `address` cannot be reached or refuses us.
    """
    if ray.is_initialized():
        return False
    if address is None:
        ray.init(address="local", num_cpus=workers, include_dashboard=False,
                 logging_level="WARNING")
        return True
    _probe(address)
    try:
        with _env("RAY_gcs_server_port_wait_time_s", GCS_CONNECT_TRIES):
            ray.init(address=address, logging_level="WARNING")
    except (ConnectionError, RuntimeError, ValueError) as err:
        raise _connection_error(address, err) from None
    except Exception as err:
        if type(err).__module__.startswith("ray"):  # e.g. ray.exceptions.AuthenticationError
            raise _connection_error(address, err) from None
        raise
    return True


class _Terminated(KeyboardInterrupt):
    """SIGTERM arrived (raised as a KeyboardInterrupt: Ray's waits turn SystemExit into 1)."""


_sigterm_seen = threading.Event()


def _sigterm_to_interrupt(signum, frame):
    _sigterm_seen.set()
    raise _Terminated


def terminated() -> bool:
    """True if SIGTERM interrupted the last Ray study of this process."""
    return _sigterm_seen.is_set()


def sigterm_exits():
    """Make SIGTERM interrupt this process (main thread only) so that cleanup code runs.

    `ray_results` turns the interrupt into SystemExit(143) once its tasks are cancelled.
    Returns the previous handler, to be restored with `signal.signal(signal.SIGTERM,
    previous)`, or None off the main thread (no change).
    """
    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, _sigterm_to_interrupt)


def _cancel(ray, refs) -> None:
    """Cancel the remote tasks of refs still running (force: their worker processes are killed).

    The finished ones are left alone: a cancel that meets a finishing task's reply aborts this
    process inside Ray (see the module docstring); the window is now that of one reply in flight.
    """
    refs = list(refs)
    if not refs:
        return
    with contextlib.suppress(Exception):  # the cluster is gone: nothing left to cancel
        _, refs = ray.wait(refs, num_returns=len(refs), timeout=0, fetch_local=False)
    for ref in refs:
        with contextlib.suppress(Exception):  # finished meanwhile, or the cluster is gone
            ray.cancel(ref, force=True)


def run_checked(job: tuple, fingerprint: str) -> tuple:
    """`run_job` on a Ray worker, refused if the worker imports other marl-social code.

    Returns run_job's result, or ("code-mismatch", where the worker's code is) if its sources
    differ from the study process's (`jobs.code_fingerprint`).
    """
    mine, places = code_fingerprint()
    if mine != fingerprint:
        return "code-mismatch", places
    return run_job(job)


def _mismatch_error(places: str) -> RayConnectionError:
    _, here = code_fingerprint()
    return RayConnectionError(
        f"a Ray worker runs other marl-social code ({places}) than this study ({here}): start "
        "every node with the Python environment in which marl-social is installed, e.g. "
        "`python -m ray.scripts.scripts start ...` with that environment's python (docs/ray.md)")


def ray_results(jobs: list[tuple], workers: int, address: str | None) -> Iterator[tuple]:
    """Results of jobs as they finish, one Ray task per job (at most 2 per CPU in flight).

    A task that fails inside Ray (e.g. its worker crashed) yields an error result. Ending
    early (the consumer stops, an exception, SIGTERM) cancels the pending tasks.
    """
    ray = import_ray()
    auth_mode = os.environ.get("RAY_AUTH_MODE")
    previous = sigterm_exits()
    _sigterm_seen.clear()
    pending: dict = {}
    started = False
    try:
        started = connect(ray, address, workers)
        sigterm_exits()  # ray.init installs its own SIGTERM handler
        remote = ray.remote(num_cpus=1)(run_checked)
        fingerprint, _ = code_fingerprint()
        window = max(2 * int(ray.cluster_resources().get("CPU", workers)), 2)
        queue = iter(jobs)
        for job in itertools.islice(queue, window):
            pending[remote.remote(job, fingerprint)] = job
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                job = pending.pop(ref)
                try:
                    result = ray.get(ref)
                except ray.exceptions.RayError as err:
                    result = (job[0], None, error_text(err), float("nan"))
                if result[0] == "code-mismatch":
                    raise _mismatch_error(result[1])
                for nxt in itertools.islice(queue, 1):
                    pending[remote.remote(nxt, fingerprint)] = nxt
                yield result
    except KeyboardInterrupt:
        if _sigterm_seen.is_set():  # Ray's wait drops the exception's type: a flag tells
            raise SystemExit(SIGTERM_EXIT_CODE) from None
        raise
    finally:
        if address is not None or not started:  # a private instance ends with its shutdown
            _cancel(ray, pending)
        if started:
            ray.shutdown()
            if address is None and auth_mode is None:  # ray.init(local) set it for itself
                os.environ.pop("RAY_AUTH_MODE", None)
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
