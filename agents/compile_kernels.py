"""Every numba kernel of marl-social, loaded (and compiled into numba's cache) ahead of a run.

Five parts are compiled on first use and cached on disk (`cache=True`, in each package's
__pycache__): the planners' kernels (models/kernel_loading.py, ~30 s), the belief's
(perception/belief/compiled.py, ~6 s), the MPC's ("tree": its tree solver, its QP's
assembly, the corridor test and its bounds: agents/robot/tree_ipm.py, qp_kernels.py,
corridor_kernels.py, ~15 s; one MPC plan compiles the last), the simulator's ("sim": the
route projection and lane test, sim/route_kernels.py, the contact test's broad phase,
sim/geometry_kernels.py, the observation's encoding, sim/observation_kernels.py, and the
env's pairwise cost features, sim/feature_kernels.py, ~6 s) and the perception's
("perception": the field of view's arithmetic around its ray queries,
perception/fov_kernels.py, and the measurements', perception/sensor_kernels.py, ~4 s; CPU
seconds of one process compiling the part alone). A
process that finds no cache compiles them itself, so on a fresh install several processes
started at once (a test run on every core, a study's workers, a vector env's) each compile the
same kernels. `compile_kernels` compiles them once, before such processes start; the parts are
independent, so two processes can compile two of them side by side: `compile_side_by_side`
splits the parts missing from the cache into groups of about equal compile time
(`split_parts`), one per usable core, and compiles them at once (the demo does so before it
builds its env, tests/conftest.py before the test workers start, .ci/run in a step of its own):

    python -c "from marl_social.agents.compile_kernels import compile_kernels; compile_kernels()"
    python -c "from marl_social.agents.compile_kernels import compile_side_by_side; compile_side_by_side()"

Processes compiling different parts write different cache files (numba keeps one index and one
data file per kernel), so they do not race; no two groups hold the same part.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from marl_social.sim.kernel_cache import will_compile

PARTS = ("planners", "belief", "tree", "sim", "perception")
# about the CPU seconds each part takes to compile alone in a fresh process, its imports
# included (the weights of `split_parts`: only their ratios matter); on 2 cores the planners
# and sim compile beside belief, tree and perception
PART_SECONDS = {"planners": 16.5, "belief": 7.0, "tree": 10.5, "sim": 5.5, "perception": 4.0}
# each part: the module whose folder holds its kernel files, and those files' names
_FILES = {
    "planners": ("marl_social.models.kernel_loading",
                 ("gap_kernels", "cost_kernels", "scene_kernels", "zone_kernels")),
    "belief": ("marl_social.perception.belief.compiled", ("belief_kernels", "view_kernels")),
    "tree": ("marl_social.agents.robot.qp", ("tree_ipm", "qp_kernels", "corridor_kernels")),
    "sim": ("marl_social.sim.road_map",
            ("route_kernels", "geometry_kernels", "observation_kernels", "feature_kernels")),
    "perception": ("marl_social.perception.fov", ("fov_kernels", "sensor_kernels")),
}


def parts_to_compile() -> list[str]:
    """The parts (of PARTS) with no numba cache as new as their kernel files.

    Empty also when the cache folders cannot be written (numba then caches elsewhere and this
    cannot tell: `sim/kernel_cache.will_compile`).
    """
    out = []
    for part in PARTS:
        module, names = _FILES[part]
        folder = Path(importlib.util.find_spec(module).origin).parent
        if will_compile(folder, names):
            out.append(part)
    return out


def split_parts(parts: tuple[str, ...] | list[str], n_groups: int) -> list[list[str]]:
    """`parts` in at most `n_groups` groups of about equal compile time (PART_SECONDS).

    Longest part first, each into the group with the least time so far (ties: the first);
    each group keeps the parts in PARTS' order; empty groups are left out, and the group with
    the most time comes first.

    Args:
        parts: parts of PARTS (repeats count once).
        n_groups: the most groups (processes) wanted, at least 1.

    Raises:
        ValueError: a part that is not one of PARTS, or n_groups < 1.
    """
    _check(parts)
    if n_groups < 1:
        raise ValueError(f"split_parts: n_groups must be at least 1, not {n_groups}")
    groups: list[list[str]] = [[] for _ in range(n_groups)]
    load = [0.0] * n_groups
    for part in sorted(set(parts), key=lambda p: (-PART_SECONDS[p], PARTS.index(p))):
        i = load.index(min(load))
        groups[i].append(part)
        load[i] += PART_SECONDS[part]
    order = sorted((i for i in range(n_groups) if groups[i]), key=lambda i: -load[i])
    return [sorted(groups[i], key=PARTS.index) for i in order]


def usable_cores() -> int:
    """How many CPUs this process may run on (its affinity where the OS tells it)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def compile_side_by_side(parts: tuple[str, ...] | list[str] | None = None,
                         processes: int | None = None) -> list[list[str]]:
    """Compile `parts` in up to `processes` processes at once, this one among them.

    The parts are split by `split_parts`; every group but the first compiles in a new Python
    process (the same interpreter and environment), the first (the longest) in this one, which
    then waits for the others. Afterwards every kernel of `parts` loads from numba's cache.

    Args:
        parts: the parts to compile (default: `parts_to_compile()`, those with no current
            cache: nothing happens when the cache is current).
        processes: the most processes compiling at once (default: `usable_cores()`).

    Returns:
        The groups, the first the one compiled in this process (empty: nothing to compile).

    Raises:
        RuntimeError: a compiling process failed (its traceback is on stderr).
        ValueError: a part that is not one of PARTS.
    """
    parts = parts_to_compile() if parts is None else list(parts)
    if not parts:
        return []
    groups = split_parts(parts, processes or usable_cores())
    code = "from marl_social.agents.compile_kernels import compile_kernels; compile_kernels({})"
    others = [subprocess.Popen([sys.executable, "-c", code.format(group)])
              for group in groups[1:]]
    try:
        compile_kernels(groups[0])
    finally:
        failed = [group for group, proc in zip(groups[1:], others) if proc.wait() != 0]
    if failed:
        raise RuntimeError(f"compile_side_by_side: compiling the numba kernels {failed} failed")
    return groups


def _check(parts) -> None:
    """Raise ValueError naming the parts (of `parts`) that are not in PARTS."""
    unknown = [p for p in parts if p not in PARTS]
    if unknown:
        raise ValueError(f"compile_kernels: unknown part(s) {unknown}; the parts are {PARTS}")


def compile_kernels(parts: tuple[str, ...] | list[str] = PARTS) -> None:
    """Load the kernels of `parts` (default: all), compiling and caching those not cached.

    Raises:
        ValueError: a part that is not one of PARTS.
    """
    _check(parts)
    if "planners" in parts:
        from marl_social.models import kernel_loading

        kernel_loading.load()
    if "belief" in parts:
        from marl_social.perception.belief import compiled

        compiled.kernels()
    if "tree" in parts:
        from marl_social.agents.robot.condensed_qp import qp_kernels

        qp_kernels()
        _solve_one_tree_qp()
        _plan_once()
    if "sim" in parts:  # the contact test; a route of several segments projects through a kernel
        from marl_social.sim.kernel_cache import (
            feature_kernels,
            geometry_kernels,
            observation_kernels,
        )
        from marl_social.sim.road_map import Lane, Route, RouteSet
        from marl_social.sim.route_rules import on_lanes

        for kernels in (geometry_kernels, observation_kernels, feature_kernels):
            kernels()  # compiled at their import (explicit signatures)
        points = [[0.0, 0.0], [10.0, 0.0], [20.0, 5.0]]
        Route(points, "compile_kernels").project(np.zeros(2))
        routes = RouteSet([Route(points, "compile_kernels")])
        routes.project(np.zeros((1, 4))[:, :2])  # the world's positions: a column slice
        lanes = [Lane(np.array(points), 3.5)]
        on_lanes(lanes, np.zeros((1, 2)), np.zeros(1))  # the lane test, headings contiguous
        on_lanes(lanes, np.zeros((2, 2)), np.zeros((2, 3))[:, 2])  # and a column of a table
    if "perception" in parts:  # compiled at their import (explicit signatures)
        from marl_social.perception.fov import fov_kernels
        from marl_social.perception.sensors import sensor_kernels

        fov_kernels()
        sensor_kernels()


def _solve_one_tree_qp() -> None:
    """One small QP through the tree solver (its kernels compile at their first call)."""
    from marl_social.agents.robot.mpc_types import MpcConfig
    from marl_social.agents.robot.qp import DAQP_MAX_BRANCHES, ContingencyQp
    from marl_social.agents.robot.qp_types import QpInstance, QpWeights
    from marl_social.sim.dynamics import DT_S

    c = MpcConfig()
    n_branches, n = DAQP_MAX_BRANCHES + 1, c.n_steps
    qp = ContingencyQp(n_branches, n, c.n_trunk, c.plan_dt_s, DT_S,
                       QpWeights(c.w_speed, c.w_accel, c.w_jerk, c.w_comfort), c.headway_s())
    stop_m = 20.0 + 5.0 * np.arange(n_branches)  # each branch stops at its own line [m]
    qp.solve(QpInstance(np.full(n_branches, 1.0 / n_branches), v0=8.0, prev_accel=0.0,
                        v_ref_mps=10.0, v_max=np.full((n_branches, n), 15.0),
                        s_low=np.full((n_branches, n), -np.inf),
                        s_up=np.repeat(stop_m[:, None], n, axis=1), accel_min=-8.0,
                        accel_max=3.0, jerk_max=c.jerk_max_mps3))


def _plan_once() -> None:
    """One MPC plan (agents/robot/mpc.py): the corridor and MPC kernels compile now.

    A curved route with a stop line, a pedestrian walking across and a car ahead in two
    hypotheses: agents/robot/corridor_kernels.py's kernels (and sim/route_kernels'
    project_footprints) compile at their first call, with the argument types a robot's
    decision gives them.
    """
    from marl_social.agents.robot.mpc import plan
    from marl_social.agents.robot.mpc_types import MpcConfig, PlanRequest
    from marl_social.models.scene_prediction import ScenePrediction
    from marl_social.sim.agent_spec import VehicleParams
    from marl_social.sim.road_map import Route

    c = MpcConfig()
    times = np.asarray(c.plan_times_s)
    route = Route([[0.0, 0.0], [40.0, 0.0], [60.0, 10.0], [70.0, 30.0]], "compile_kernels")
    walker = np.stack([np.full(len(times), 30.0), -4.0 + 1.3 * times], axis=-1)  # (T, 2) [m]
    car = np.stack([45.0 + 2.0 * times, np.zeros(len(times))], axis=-1)
    both = np.ones((2, 2), bool)
    scene = ScenePrediction(
        np.repeat(np.stack([walker, car])[None], 2, axis=0),
        np.repeat(np.array([[np.pi / 2], [0.0]]) * np.ones(len(times)), 2, axis=0).reshape(
            2, 2, -1),
        np.array([[0.6, 4.5]] * 2), np.array([[0.6, 1.8]] * 2), np.array([[0.3, 2.4]] * 2),
        both & [True, False], both & [[True], [False]] | both & [False, True])
    plan(c, VehicleParams(), route, PlanRequest(
        10.0, 8.0, 0.0, 10.0, 13.9, scene, np.array([0.3, 0.7]),
         stop_at_m=50.0))
