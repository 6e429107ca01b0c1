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
