"""Studies on Ray: a real `ray start --head` cluster through --address gives the local
table; a client without the cluster's token gets a one-line error with the fix; SIGTERM of a
Ray study cancels its tasks (the cluster's CPU is free again) and leaves no local process."""

from __future__ import annotations

import importlib.util
import os
import secrets
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from marl_social.studies import runner as studies
from marl_social.studies.jobs import code_fingerprint
from marl_social.studies.ray_backend import run_checked
from tests.studies.test_kill import _alive, _children, _descendants

# skipped without Ray; found, not imported: Ray takes ~0.6 s to import, in every xdist worker
pytestmark = pytest.mark.skipif(importlib.util.find_spec("ray") is None, reason="needs ray")

TINY = """
name = "tiny-ray"
seeds = 2
planners = ["social", "aggressive"]
pedestrians = ["crossing"]
max_cycles = 25
metrics = ["robot_collision", "time_to_pass_s", "min_gap_pedestrian_m"]
"""
LONG = """
name = "long-ray"
seeds = 40
planners = ["social"]
pedestrians = ["crossing"]
max_cycles = 150
metrics = ["robot_collision", "time_to_pass_s"]
"""
STUDY = [sys.executable, "-m", "marl_social.studies"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _processes_of(temp_dir: str) -> set[int]:
    """Pids whose command line names temp_dir (the cluster's daemons), and their children."""
    own = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if temp_dir.encode() in (entry / "cmdline").read_bytes():
                    own.add(int(entry.name))
            except OSError:
                continue
    for pid in list(own):
        own |= _descendants(pid)
    return own


def _content(path: Path) -> list[tuple]:
    _, rows = studies.read_results(path)
    return sorted(tuple((k, v) for k, v in r.items() if k != "elapsed_s") for r in rows)


@pytest.fixture(scope="module")
def cluster():
    """A one-CPU Ray head with token authentication in a private temp dir: (address, env)."""
    temp_dir = tempfile.mkdtemp(prefix="ray", dir="/tmp")  # short: Ray's socket paths
    port = _free_port()
    env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(16)}
    start = subprocess.run(
        [sys.executable, "-m", "ray.scripts.scripts", "start", "--head", "--port", str(port),
         "--num-cpus", "1", "--temp-dir", temp_dir, "--include-dashboard", "false",
         "--disable-usage-stats"], check=False, env=env, capture_output=True, text=True,
        timeout=120)
    try:
        assert start.returncode == 0, start.stderr[-2000:]
        yield f"127.0.0.1:{port}", env
    finally:  # `ray stop` would stop every Ray on the machine: end only this cluster's pids
        pids = _processes_of(temp_dir)
        for pid in pids:
            os.kill(pid, signal.SIGKILL)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and any(_alive(p) for p in pids):
            time.sleep(0.1)
        subprocess.run(["rm", "-rf", temp_dir], check=False)


def _run(args: list[str], env: dict, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([*STUDY, *args, "--no-progress", "--no-plots"], check=False,
                          env=env, capture_output=True, text=True, timeout=timeout)


@pytest.mark.slow
def test_cluster_gives_the_local_table_and_a_one_line_error_without_the_token(cluster,
                                                                             tmp_path):
    address, env = cluster
    spec = tmp_path / "tiny.toml"
    spec.write_text(TINY)
    # the reference table in this process (test_studies: a pool's table is the same)
    local = studies.run_study(spec, tmp_path / "local", workers=1, progress=False,
                              summary="none")
    done = _run([str(spec), "--out", str(tmp_path / "ray"), "--backend", "ray", "--address",
                 address], env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert _content(tmp_path / "ray" / studies.RESULTS_FILE) == _content(local.results_path)
    assert studies.load(tmp_path / "ray").drop(columns="elapsed_s").equals(
        studies.load(tmp_path / "local").drop(columns="elapsed_s"))

    no_token = {k: v for k, v in env.items() if not k.startswith("RAY_AUTH")}
    refused = _run([str(spec), "--out", str(tmp_path / "refused"), "--backend", "ray",
                    "--address", address], no_token, timeout=120)
    assert refused.returncode == 2
    assert "Traceback" not in refused.stderr and "ConnectionError" not in refused.stderr
    error = [line for line in refused.stderr.splitlines() if line.startswith("error: ")]
    assert len(error) == 1 and "requires token authentication" in error[0], refused.stderr
    assert "RAY_AUTH_MODE=token" in error[0] and "RAY_AUTH_TOKEN" in error[0]

    nobody = _run([str(spec), "--out", str(tmp_path / "nobody"), "--backend", "ray",
                   "--address", f"127.0.0.1:{_free_port()}"], env, timeout=120)
    assert nobody.returncode == 2 and "Traceback" not in nobody.stderr
    assert "error: cannot reach the Ray cluster" in nobody.stderr
    assert "ray start --head" in nobody.stderr


@pytest.mark.slow
def test_sigterm_cancels_the_tasks_on_the_cluster(cluster, tmp_path):
    address, env = cluster
    spec = tmp_path / "long.toml"
    spec.write_text(LONG)
    table = tmp_path / "out" / studies.RESULTS_FILE
    proc = subprocess.Popen([*STUDY, str(spec), "--out", str(tmp_path / "out"), "--backend",
                             "ray", "--address", address, "--no-progress", "--no-plots"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _wait_for_rows(proc, table, 1)
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=60) == 128 + signal.SIGTERM
    code = ("import ray, time\n"
            f"ray.init(address={address!r}, logging_level='ERROR')\n"
            "deadline = time.monotonic() + 20\n"
            "while ray.available_resources().get('CPU', 0) < 1 and time.monotonic() < deadline:\n"
            "    time.sleep(0.2)\n"
            "print('free CPUs', ray.available_resources().get('CPU', 0))\n")
    probe = subprocess.run([sys.executable, "-c", code], check=False, env=env,
                           capture_output=True, text=True, timeout=120)
    assert "free CPUs 1.0" in probe.stdout, probe.stdout + probe.stderr[-2000:]
    _, rows = studies.read_results(table)
    assert 1 <= len(rows) < 40  # the finished runs are kept for --resume


def _wait_for_rows(proc: subprocess.Popen, table: Path, n: int, timeout_s: float = 180) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None:
        if table.exists() and table.read_bytes().count(b"\n") >= 1 + n:
            return
        time.sleep(0.1)
    pytest.fail(f"no {n} finished run(s) before the kill: {proc.poll()} "
                f"{proc.stderr.read().decode()[-2000:] if proc.poll() is not None else ''}")


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_sigterm_of_a_local_ray_study_leaves_no_process(tmp_path):
    spec = tmp_path / "long.toml"
    spec.write_text(LONG)
    table = tmp_path / "out" / studies.RESULTS_FILE
    proc = subprocess.Popen([*STUDY, str(spec), "--out", str(tmp_path / "out"), "--backend",
                             "ray", "--workers", "1", "--no-progress", "--no-plots"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _wait_for_rows(proc, table, 1)
    family = _descendants(proc.pid)  # the private Ray: gcs_server, raylet, workers, ...
    assert len(family) >= 3, family
    proc.send_signal(signal.SIGTERM)
    code = proc.wait(timeout=60)
    assert code == 128 + signal.SIGTERM, proc.stderr.read().decode()[-3000:]
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline and any(_alive(p) for p in family):
        time.sleep(0.2)
    survivors = sorted(p for p in family if _alive(p) and p in _children())
    for pid in survivors:  # do not leave them to the rest of the suite
        os.kill(pid, signal.SIGKILL)
    assert survivors == [], f"processes of the terminated study still running: {survivors}"


def test_a_worker_with_other_code_is_refused():
    job = ("k", "occluded_crosswalk", 0, 5, {"robot_planner": "social"}, ("robot_collision",))
    fingerprint, places = code_fingerprint()
    assert run_checked(job, "0" * 64) == ("code-mismatch", places)
    key, values, error, _ = run_checked(job, fingerprint)
    assert (key, error) == ("k", None) and values == {"robot_collision": False}


@pytest.mark.parametrize("address, message", [
    ("127.0.0.1:{port}", ("error: cannot reach the Ray cluster at 127.0.0.1:{port} "
                         "(Connection refused): start its head with `ray start --head --port "
                         "{port}`")),
    ("headnode", "error: --address 'headnode': expected HOST:PORT of a Ray head"),
])
def test_no_cluster_at_the_address_is_one_line_with_the_fix(tmp_path, capsys, address,
                                                            message):
    spec = tmp_path / "tiny.toml"
    spec.write_text(TINY)
    port = _free_port()
    assert studies.main([str(spec), "--out", str(tmp_path / "out"), "--backend", "ray",
                         "--address", address.format(port=port), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(message.format(port=port)) and err.count("\n") == 1, err
    assert not (tmp_path / "out" / studies.RESULTS_FILE).exists() or \
        studies.read_results(tmp_path / "out" / studies.RESULTS_FILE)[1] == []
    # nothing ran, so the same folder takes the study without --resume or --overwrite
    outcome = studies.run_study(spec, tmp_path / "out", progress=False, summary="none")
    assert (outcome.n_runs, outcome.n_executed, outcome.n_errors) == (4, 4, 0)
