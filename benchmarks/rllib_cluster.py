"""`marl-social train --address` on a real `ray start --head` cluster, one env runner killed.

    python benchmarks/rllib_cluster.py [--iterations N] [--env-runners K]

Starts a Ray head with token authentication in a private temp dir (docs/ray.md's recipe: the
study process and the head share RAY_AUTH_MODE=token and RAY_AUTH_TOKEN), runs

    marl-social train --address 127.0.0.1:PORT --env-runners K --iterations N ...

against it, and once the log has its second row kills one env runner's process (SIGKILL: as a
lost node or an OOM kill would). The run must finish with N rows, the columns of a local run,
and RLlib's count of restarted env runners >= 1 (`env_runner_restarts`). Only the cluster's
own processes are ended afterwards (those whose command line names its temp dir, and their
children): `ray stop` would stop every Ray on the machine.
"""

from __future__ import annotations

import argparse
import csv
import os
import secrets
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


def _pids() -> list[int]:
    return [int(p.name) for p in Path("/proc").iterdir() if p.name.isdigit()]


def _parent(pid: int) -> int:
    try:
        return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
    except (OSError, ValueError, IndexError):
        return -1


def cluster_pids(temp_dir: str) -> set[int]:
    """The cluster's processes: command lines naming temp_dir, and their descendants."""
    own = {pid for pid in _pids() if temp_dir.encode() in _cmdline(pid)}
    grew = True
    while grew:
        more = {pid for pid in _pids() if _parent(pid) in own} - own
        own |= more
        grew = bool(more)
    return own


def env_runner_pids(temp_dir: str) -> list[int]:
    """The cluster's env runner worker processes (Ray names them ray::MultiAgentEnvRunner)."""
    return sorted(pid for pid in cluster_pids(temp_dir)
                  if b"MultiAgentEnvRunner" in _cmdline(pid))


def _rows(log: Path) -> list[dict]:
    if not log.exists():
        return []
    with log.open(newline="") as f:
        return list(csv.DictReader(f))


def main() -> int:
    """Run the check; print what happened; exit code 0 if the run survived the kill."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--iterations", type=int, default=12)
    parser.add_argument("--env-runners", type=int, default=2)
    parser.add_argument("--batch", type=int, default=400)
    args = parser.parse_args()
    temp_dir = tempfile.mkdtemp(prefix="ray", dir="/tmp")  # short: Ray's socket paths
    out = Path(tempfile.mkdtemp(prefix="rllib-cluster-run-"))
    port = _free_port()
    env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(16),
           "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    start = subprocess.run(
        [sys.executable, "-m", "ray.scripts.scripts", "start", "--head", "--port", str(port),
         "--num-cpus", str(args.env_runners + 1), "--temp-dir", temp_dir,
         "--include-dashboard", "false", "--disable-usage-stats"],
        env=env, capture_output=True, text=True, timeout=180, check=False)
    if start.returncode != 0:
        print(start.stderr[-2000:])
        return 1
    command = [sys.executable, "-m", "marl_social", "train", "--address", f"127.0.0.1:{port}",
               "--env-runners", str(args.env_runners), "--iterations", str(args.iterations),
               "--batch", str(args.batch), "--minibatch", str(args.batch // 2), "--epochs", "2",
               "--max-cycles", "100", "--out", str(out), "--no-progress"]
    print("$ RAY_AUTH_MODE=token RAY_AUTH_TOKEN=... " + " ".join(command[1:]).replace(
        "-m marl_social", "marl-social"))
    t0 = time.monotonic()
    killed = None
    try:
        run = subprocess.Popen(command, env=env, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True)
        while run.poll() is None:
            if killed is None and len(_rows(out / "progress.csv")) >= 2:
                runners = env_runner_pids(temp_dir)
                if runners:
                    killed = runners[0]
                    os.kill(killed, signal.SIGKILL)
                    print(f"killed env runner pid {killed} after iteration 2 "
                          f"({time.monotonic() - t0:.0f} s; runners were {runners})")
            time.sleep(0.5)
        output = run.stdout.read()
    finally:
        for pid in cluster_pids(temp_dir):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        subprocess.run(["rm", "-rf", temp_dir], check=False)
    rows = _rows(out / "progress.csv")
    print(f"train exited {run.returncode} after {time.monotonic() - t0:.0f} s; "
          f"{len(rows)} rows in {out / 'progress.csv'}")
    print("columns:", ", ".join(rows[0]) if rows else "-")
    for row in rows:
        print(f"  iteration {row['iteration']:>2}: env_steps {row['env_steps']:>5}, "
              f"return {float(row['return_mean']):7.2f}, healthy runners "
              f"{row['env_runners_healthy']}, restarts {row['env_runner_restarts']}")
    survived = (run.returncode == 0 and len(rows) == args.iterations and killed is not None
                and int(rows[-1]["env_runner_restarts"]) >= 1)
    if not survived:
        print(output[-3000:])
    print("OK: the run survived the killed env runner" if survived else "FAILED")
    return 0 if survived else 1


if __name__ == "__main__":
    raise SystemExit(main())
