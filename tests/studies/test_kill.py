"""A SIGKILLed 2-worker study leaves no process behind (pool workers, resource tracker)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

SPEC = """
name = "kill"
seeds = 40
planners = ["social"]
pedestrians = ["crossing"]
max_cycles = 60
"""


def _children() -> dict[int, int]:
    """{pid: parent pid} of every process (Linux /proc)."""
    out = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            out[int(entry.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    return out


def _descendants(pid: int) -> set[int]:
    parents = _children()
    found, frontier = set(), {pid}
    while frontier:
        frontier = {p for p, pp in parents.items() if pp in frontier} - found
        found |= frontier
    return found


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"  # a zombie has exited


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_sigkill_of_a_two_worker_study_leaves_no_process(tmp_path):
    spec = tmp_path / "kill.toml"
    spec.write_text(SPEC)
    table = tmp_path / "out" / "results.csv"
    proc = subprocess.Popen([sys.executable, "-m", "marl_social.studies", str(spec), "--out",
                             str(tmp_path / "out"), "--workers", "2", "--no-progress",
                             "--no-plots"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline, family = time.monotonic() + 120, set()
    while time.monotonic() < deadline and proc.poll() is None:
        family |= _descendants(proc.pid)
        if len(family) >= 3 and table.exists() and table.read_bytes().count(b"\n") >= 2:
            break  # two workers and the resource tracker, and a finished run
        time.sleep(0.05)
    assert proc.poll() is None, f"the study ended before the kill: {proc.stderr.read()}"
    family |= _descendants(proc.pid)
    assert len(family) >= 2, family
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    time.sleep(5.0)
    survivors = sorted(p for p in family if _alive(p))
    for pid in survivors:  # do not leave them to the rest of the suite
        os.kill(pid, signal.SIGKILL)
    assert survivors == [], f"processes of the killed study still running: {survivors}"
