"""What the MPC's QPs set up ahead or late: the layouts built with the planner, OSQP at its first use.

Neither may change a result: an OSQP set up at the first fallback starts from the state a setup
at construction leaves (it is never touched before), and a layout built ahead is the one a plan
would have built (process-wide, read only).
"""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.agents.robot import qp
from marl_social.agents.robot.mpc import ContingencyMpc
from marl_social.agents.robot.mpc_types import MpcConfig
from marl_social.agents.robot.qp_types import QpInstance, QpSolution
from marl_social.sim.agent_spec import VehicleParams
from tests.agents.test_condensed_qp import _captured, _qp


def _bits(solution: QpSolution) -> tuple:
    return (solution.solved, solution.cost, solution.accel_mps2.tobytes(),
            solution.speed_mps.tobytes(), solution.progress_m.tobytes())


@pytest.mark.parametrize("n_branches", [1, 2, 3])
def test_osqp_set_up_at_its_first_fallback_gives_the_bits_of_one_set_up_at_construction(
        n_branches, monkeypatch):
    """The captured QPs of L branches in order, each solved once by DAQP (3 branches: the tree
    solver) and once by the OSQP fallback (the other solvers taken away): the QP that sets OSQP
    up only at the first fallback answers bit for bit as the one set up when it was made."""
    cases = [c for c in _captured() if c["weights"].shape == (n_branches,)]
    assert cases
    lazy, eager = _qp(n_branches), _qp(n_branches)
    eager._setup_osqp()
    answers = {id(lazy): [], id(eager): []}
    for problem in (lazy, eager):
        for args in cases:
            answers[id(problem)].append(_bits(problem.solve(QpInstance(**args))))
        assert problem.solver_counts["osqp"] == 0
        monkeypatch.setattr(problem, "_condensed", None)
        monkeypatch.setattr(problem, "_tree", None)
        for args in cases:
            answers[id(problem)].append(_bits(problem.solve(QpInstance(**args))))
        monkeypatch.undo()
        assert problem.solver_counts["osqp"] > 0
    assert answers[id(lazy)] == answers[id(eager)]


def test_a_qp_that_never_falls_back_sets_up_no_osqp():
    problem = _qp(2)
    for args in _captured():
        if args["weights"].shape == (2,):
            problem.solve(QpInstance(**args))
    assert problem.solver_counts["osqp"] == 0 and problem._solver is None


def test_layouts_built_ahead_are_the_ones_the_plans_use(monkeypatch):
    """After build_layouts(5) the QPs of 1..5 branches build nothing: their structure is the
    process-wide one built ahead (the same arrays)."""
    config = MpcConfig(horizon_s=5.0)  # a layout no other test builds
    mpc = ContingencyMpc(config, VehicleParams())
    mpc.build_layouts(5)

    def no_build(self, headway_s):
        raise AssertionError("a layout built at its first use")

    monkeypatch.setattr(qp.ContingencyQp, "_build_structure", no_build)
    first = [mpc._qp(n) for n in range(1, 6)]
    assert [p.n_branches for p in first] == [1, 2, 3, 4, 5]
    assert first[2]._tree is not None and first[1]._condensed is not None
    mpc.reset()
    again = [mpc._qp(n) for n in range(1, 6)]
    assert all(a is not b and a._a_matrix is b._a_matrix for a, b in zip(first, again))
    assert np.array_equal(again[0]._lower_template, first[0]._lower_template)
