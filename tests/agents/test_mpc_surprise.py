"""Infeasible plans: which ones a comfortable stop one step earlier would have met, and the
contingencies given way to a comfortable stop."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from marl_social.agents.robot.corridor import PathObject
from marl_social.agents.robot.give_way import comfortable_stop_meets
from marl_social.agents.robot.mpc import ContingencyMpc
from marl_social.agents.robot.mpc_types import BrakingStart, MpcConfig, PlanRequest
from marl_social.evaluation.run import infeasible_steps
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.dynamics import DT_S
from marl_social.sim.road_map import Route

ROUTE = Route([[-50.0, 1.75], [200.0, 1.75]])  # s = x + 50
CONFIG = MpcConfig()
TIMES = CONFIG.plan_times_s
VEHICLE = VehicleParams()


def _empty(n_hyp: int) -> ScenePrediction:
    z = np.zeros((n_hyp, 0))
    return ScenePrediction(np.zeros((n_hyp, 0, len(TIMES), 2)), np.zeros((n_hyp, 0, len(TIMES))),
                           z, z, z, z.astype(bool), z.astype(bool))


def _request(s0: float, v0: float, n_hyp: int = 1, **kw) -> PlanRequest:
    return PlanRequest(s0, v0, 0.0, v0, 13.9, _empty(n_hyp), np.full(n_hyp, 1.0 / n_hyp), **kw)


def test_comfortable_stop_meets_a_bound_beyond_its_stopping_distance_only():
    """From 10 m/s braking at 2.5 m/s^2 (after the jerk-limited onset) stops in about 21 m."""
    start = BrakingStart(0.0, 10.0, 0.0, DT_S)
    no_headway = np.zeros(len(TIMES))
    free = np.full(len(TIMES), 20.0)

    def meets(bound_m, v_max=free):
        return comfortable_stop_meets(start, np.full(len(TIMES), bound_m), v_max, TIMES,
                                      no_headway, CONFIG.comfort_decel_mps2,
                                      CONFIG.jerk_max_mps3)

    assert meets(22.0) and meets(np.inf)
    assert not meets(19.0)
    assert not meets(np.inf, v_max=np.full(len(TIMES), 5.0))  # too fast for a speed bound


@pytest.mark.parametrize("jump_m, surprise", [(1.0, False), (25.0, True)])
def test_an_infeasible_plan_is_a_surprise_only_if_a_comfortable_stop_a_step_earlier_met_it(
        jump_m, surprise):
    """A stop line 3 m ahead at 10 m/s: no stop meets it. One step earlier, 1 m further back,
    no comfortable stop did either; from 25 m back (a position estimate that jumped) one did."""
    mpc = ContingencyMpc(CONFIG, VEHICLE)
    s_now = 100.0
    assert mpc.plan(ROUTE, _request(s_now - jump_m, 10.0)).feasible
    res = mpc.plan(ROUTE, _request(s_now, 10.0, stop_at_m=s_now + 3.0))
    assert not res.feasible and res.accel_mps2 == -VEHICLE.brake_max_mps2
    assert res.surprise_infeasible is surprise
    mpc.reset()  # no earlier step in a new episode
    assert not mpc.plan(ROUTE, _request(s_now, 10.0, stop_at_m=s_now + 3.0)).surprise_infeasible


def _zone_claim(s0: float, pedestrian: bool = False, from_s: float = 2.0,
                length_m: float = 58.0) -> PathObject:
    """A zone from 2 m ahead of the robot's centre (its front is past the stay-behind bound),
    claimed from `from_s` on; by default too long to be cleared in time."""
    n = len(TIMES)
    occupied = TIMES >= from_s
    return PathObject(occupied, np.full(n, s0 + 2.0), np.full(n, s0 + 2.0 + length_m),
                      int(np.argmax(occupied)), n - 1, is_pedestrian=pedestrian,
                      pass_margin=False)


def _plan_with_claims(claims: list[list[PathObject]], s0: float = 100.0, v0: float = 3.0):
    contingent = np.array([False, True])  # "none" and a hidden agent
    return ContingencyMpc(CONFIG, VEHICLE).plan(ROUTE, _request(
        s0, v0, 2, contingent=contingent, extra_objects=claims))


def test_a_hidden_car_it_can_no_longer_stop_for_is_met_with_a_comfortable_stop():
    """A zone claimed by a hypothesised car only (a contingency branch's own object): no plan
    stays behind it, so its bound gives way to a comfortable stop instead of the limit."""
    s0 = 100.0
    res = _plan_with_claims([[], [_zone_claim(s0)]], s0)
    assert res.feasible and res.contingency_given_way
    assert -CONFIG.comfort_decel_mps2 - 0.5 <= res.accel_mps2 < 0.0


def test_a_hidden_car_it_can_neither_stop_for_nor_pass_beside_a_tracked_one_is_left_out():
    """A tracked car claims a short zone late (the robot passes in front of it); the hidden
    car's claim of the same zone comes earlier: a comfortable stop for it would undo the pass,
    so it is left out and the robot goes on."""
    s0 = 100.0
    tracked = _zone_claim(s0, from_s=5.0, length_m=8.0)
    res = _plan_with_claims([[tracked], [tracked, _zone_claim(s0)]], s0)
    assert res.feasible and res.contingency_given_way and res.modes[1] == ("past",)
    assert res.accel_mps2 >= -0.1


def test_a_tracked_car_or_a_hidden_pedestrian_it_cannot_stop_for_still_brakes_at_the_limit():
    """The same claim in every branch (a tracked car), or a hypothesised pedestrian's: the
    robot brakes as hard as it can."""
    s0 = 100.0
    for claims in ([[_zone_claim(s0)], [_zone_claim(s0)]], [[], [_zone_claim(s0, True)]]):
        res = _plan_with_claims(claims, s0)
        assert not res.feasible and not res.contingency_given_way
        assert res.accel_mps2 == -VEHICLE.brake_max_mps2


def test_infeasible_steps_count_the_recorded_flags():
    trace = SimpleNamespace(extras={
        "mpc_infeasible": np.array([0.0, 1.0, 1.0, 0.0, np.nan]),
        "mpc_surprise_infeasible": np.array([0.0, 0.0, 1.0, 0.0, np.nan]),
        "mpc_contingency_given_way": np.array([0.0, 0.0, 0.0, 1.0, np.nan])})
    assert infeasible_steps(trace) == {"mpc_infeasible_steps": 2, "surprise_infeasible_steps": 1,
                                       "contingency_given_way_steps": 1}
    assert set(infeasible_steps(SimpleNamespace(extras={})).values()) == {0}
