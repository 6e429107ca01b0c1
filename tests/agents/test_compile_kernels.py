"""compile_kernels: every numba kernel loaded ahead, so that parallel processes find a cache."""

from __future__ import annotations

import pytest

from marl_social.agents import compile_kernels as ck
from marl_social.agents.robot import qp as qp_module


def test_after_compiling_no_part_is_left_to_compile():
    ck.compile_kernels()
    assert ck.parts_to_compile() == []


def test_the_tree_part_solves_its_qp_on_the_tree_solver(monkeypatch):
    seen = []
    solve = qp_module.ContingencyQp.solve

    def spy(self, *args, **kwargs):
        solution = solve(self, *args, **kwargs)
        seen.append((self.last_solver, solution.solved))
        return solution

    monkeypatch.setattr(qp_module.ContingencyQp, "solve", spy)
    ck.compile_kernels(["tree"])
    # its QP on the tree solver, then one MPC plan (the corridor kernels) through DAQP
    assert seen[0] == ("tree", True)
    assert seen[1:] and all(solver == "daqp" and solved for solver, solved in seen[1:])


def test_a_stale_kernel_file_is_a_part_to_compile(monkeypatch):
    stale = {"belief_kernels"}
    monkeypatch.setattr(ck, "will_compile", lambda folder, names: bool(stale & set(names)))
    assert ck.parts_to_compile() == ["belief"]


def test_an_unknown_part_is_refused_by_name():
    with pytest.raises(ValueError, match=r"unknown part\(s\) \['gpu'\].*'planners'"):
        ck.compile_kernels(["gpu"])


def test_the_sim_part_compiles_the_simulators_kernels(monkeypatch):
    from marl_social.sim import geometry_kernels, kernel_cache, route_kernels

    calls = []
    project = route_kernels.project_points
    monkeypatch.setattr(route_kernels, "project_points",
                        lambda *args: calls.append(1) or project(*args))
    ck.compile_kernels(["sim"])
    assert calls == [1]
    assert kernel_cache._LOADED[("marl_social.sim", ("route_kernels",))] == (route_kernels,)
    assert kernel_cache._LOADED[("marl_social.sim", ("geometry_kernels",))] == (
        geometry_kernels,)
    assert ("marl_social.sim", ("observation_kernels",)) in kernel_cache._LOADED
    assert ("marl_social.sim", ("feature_kernels",)) in kernel_cache._LOADED


def test_the_perception_part_loads_the_field_of_view_and_sensor_kernels():
    from marl_social.perception import fov_kernels, sensor_kernels
    from marl_social.sim import kernel_cache

    ck.compile_kernels(["perception"])
    assert kernel_cache._LOADED[("marl_social.perception", ("fov_kernels",))] == (fov_kernels,)
    assert kernel_cache._LOADED[("marl_social.perception", ("sensor_kernels",))] == (
        sensor_kernels,)
    assert "perception" not in ck.parts_to_compile()


def test_the_parts_split_into_groups_of_about_equal_compile_time():
    groups = ck.split_parts(ck.PARTS, 2)
    assert sorted(p for g in groups for p in g) == sorted(ck.PARTS)  # each part once
    times = [sum(ck.PART_SECONDS[p] for p in g) for g in groups]
    assert times[0] >= times[1]  # the longest group first (the calling process compiles it)
    assert times[0] - times[1] <= min(ck.PART_SECONDS.values())
    assert groups == [["planners", "sim"], ["belief", "tree", "perception"]]  # PARTS' order


def test_the_split_leaves_out_empty_groups_and_repeats():
    assert ck.split_parts(["sim", "belief", "sim"], 4) == [["belief"], ["sim"]]
    assert ck.split_parts(["tree", "sim"], 1) == [["tree", "sim"]]
    assert ck.split_parts([], 2) == []
    with pytest.raises(ValueError, match="n_groups"):
        ck.split_parts(["sim"], 0)
    with pytest.raises(ValueError, match=r"unknown part\(s\) \['gpu'\]"):
        ck.split_parts(["gpu"], 2)


def test_side_by_side_compiles_nothing_when_the_cache_is_current(monkeypatch):
    monkeypatch.setattr(ck, "parts_to_compile", list)
    monkeypatch.setattr(ck, "compile_kernels", lambda parts: pytest.fail("compiled"))
    assert ck.compile_side_by_side() == []


def test_side_by_side_compiles_the_longest_group_here_and_the_others_in_processes(monkeypatch):
    here, started = [], []

    class Process:
        def __init__(self, args):
            started.append(args[-1])

        def wait(self):
            return 0

    monkeypatch.setattr(ck.subprocess, "Popen", Process)
    monkeypatch.setattr(ck, "compile_kernels", here.append)
    groups = ck.compile_side_by_side(["sim", "planners", "belief"], processes=2)
    assert groups == [["planners"], ["belief", "sim"]]
    assert here == [["planners"]]
    assert len(started) == 1 and started[0].endswith("compile_kernels(['belief', 'sim'])")


def test_side_by_side_reports_a_failed_process(monkeypatch):
    class Failing:
        def __init__(self, args):
            pass

        def wait(self):
            return 1

    monkeypatch.setattr(ck.subprocess, "Popen", Failing)
    monkeypatch.setattr(ck, "compile_kernels", lambda parts: None)
    with pytest.raises(RuntimeError, match=r"\[\['sim'\]\] failed"):
        ck.compile_side_by_side(["planners", "sim"], processes=2)
