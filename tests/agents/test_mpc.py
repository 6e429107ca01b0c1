"""The contingency MPC: defensive for every live hypothesis, weighted by belief, epsilon tail."""

from __future__ import annotations

import numpy as np
import pytest
from marl_social.agents.robot.mpc import MpcConfig, plan

from marl_social.models.candidates import ScenePrediction
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.road_map import Crosswalk, Route

ROUTE = Route([[-50.0, 1.75], [200.0, 1.75]])
CROSSWALK = Crosswalk(np.array([40.0, 0.0]), np.pi / 2, 7.0, 4.0)
CONFIG = MpcConfig()
TIMES = CONFIG.candidates.plan_times_s


def _scene(pedestrian_walks: list[bool]) -> ScenePrediction:
    """One hypothesis per entry: a pedestrian starting on the right curb of the crosswalk and
    walking across at 1.3 m/s (True) or absent (False)."""
    n = len(pedestrian_walks)
    start = np.array([40.0, -4.5])
    xy = np.broadcast_to(start + np.outer(TIMES * 1.3, [0.0, 1.0]), (n, 1, len(TIMES), 2))
    return ScenePrediction(
        xy=xy.copy(), heading=np.full((n, 1, len(TIMES)), np.pi / 2),
        length_m=np.full((n, 1), 0.6), width_m=np.full((n, 1), 0.6),
        radius_m=np.full((n, 1), 0.3), is_pedestrian=np.ones((n, 1), bool),
        mask=np.array(pedestrian_walks)[:, None],
    )


def _plan(beliefs, walks, s0=30.0, v0=11.5):
    return plan(CONFIG, VehicleParams(), ROUTE, s0, v0, 0.0, 11.5, 13.9, _scene(walks),
                np.array(beliefs), (CROSSWALK,))


def test_no_hazard_keeps_speed():
    res = _plan([1.0], [False])
    assert res.feasible and res.accel_mps2 == 0.0


def test_certain_crossing_pedestrian_makes_it_brake():
    # the route starts at x = -50: s0 = 60 is 30 m before the crosswalk (x = 40), s0 = 72 is 18 m
    far = _plan([1.0], [True], s0=60.0)
    near = _plan([1.0], [True], s0=72.0)
    assert far.accel_mps2 <= 0.0
    assert near.accel_mps2 <= -2.0


def test_unlikely_hypothesis_still_constrains_but_costs_little():
    """b = 0.1 >= epsilon: the robot keeps a stopping branch (defensive) but brakes less than
    when the pedestrian is certain (not overly conservative)."""
    certain = _plan([0.0, 1.0], [False, True], s0=72.0)
    unlikely = _plan([0.9, 0.1], [False, True], s0=72.0)
    assert unlikely.feasible and certain.feasible
    assert certain.accel_mps2 <= unlikely.accel_mps2
    # the chosen first action has a feasible branch under the unlikely hypothesis too
    k = CONFIG.candidates.first_actions_mps2.index(unlikely.accel_mps2)
    assert np.isfinite(unlikely.expected_cost[k])


def test_epsilon_tail_threshold_ignores_rare_hypotheses():
    tail = _plan([0.99, 0.01], [False, True], s0=72.0)
    none = _plan([1.0], [False], s0=72.0)
    assert not tail.live[1]
    assert tail.accel_mps2 == none.accel_mps2 == 0.0


def test_no_feasible_plan_brakes_as_hard_as_possible():
    # 6 m before the crosswalk at 11.5 m/s: no branch can stop in time
    res = _plan([1.0], [True], s0=84.0)
    assert not res.feasible
    assert res.accel_mps2 == min(CONFIG.candidates.first_actions_mps2)


def test_beliefs_are_renormalized_over_live_hypotheses():
    res = _plan([0.5, 0.3, 0.2], [False, True, True], s0=60.0)
    assert res.weights.sum() == pytest.approx(1.0)
    assert res.weights == pytest.approx([0.5, 0.3, 0.2])


def test_static_polygon_ahead_is_a_constraint():
    """A parked truck across the lane 28 m ahead of the robot's front: without it the robot
    keeps speed; with it the robot plans to stop short of it."""
    boxes = np.array([[110.0, 0.0, 118.0, 3.5]])  # robot at s0 = 130: x = 80
    free = plan(CONFIG, VehicleParams(), ROUTE, 130.0, 11.5, 0.0, 11.5, 13.9, _scene([False]),
                np.array([1.0]), ())
    blocked = plan(CONFIG, VehicleParams(), ROUTE, 130.0, 11.5, 0.0, 11.5, 13.9,
                   _scene([False]), np.array([1.0]), (), static_boxes=boxes)
    assert free.accel_mps2 == 0.0
    assert blocked.feasible and blocked.accel_mps2 < 0.0


def test_car_stopped_in_the_next_lane_does_not_block_the_robot():
    """A stopped car's velocity estimate is noise: its tracked footprint keeps the measured
    heading (along the road), so the robot passing it in its own lane keeps its speed. Turned
    to the direction of the noise (across the road), the 4.5 m car would reach into the
    robot's lane and force it to brake."""
    from marl_social.perception.tracking import Tracker

    from marl_social.sim.observation import EGO_DIM, SLOT_FIELDS, SLOT_INDEX, ObservationLayout

    layout = ObservationLayout(n_slots=2, n_rays=4)
    f = SLOT_INDEX
    tracker = Tracker(pos_noise_m=0.05, vel_noise_mps=0.1)
    rng = np.random.default_rng(3)
    for _ in range(20):  # stopped at x = 95 in the right lane (y = -1.75), heading along +x
        vec = np.zeros(layout.size, dtype=np.float32)
        slot = vec[EGO_DIM:EGO_DIM + len(SLOT_FIELDS)]
        slot[f["present"]], slot[f["id"]] = 1.0, 2.0
        slot[f["x"]], slot[f["y"]] = 95.0 + rng.normal(0, 0.05), -1.75 + rng.normal(0, 0.05)
        slot[f["vx"]], slot[f["vy"]] = 0.0, 0.3  # the noise points across the road
        slot[f["cos_psi"]], slot[f["sin_psi"]] = 1.0, 0.0
        slot[f["length"]], slot[f["width"]] = 4.5, 1.8
        tracks = tracker.update(layout.decode(vec))
    assert tracks.heading_rad[0] == pytest.approx(0.0)
    scene = ScenePrediction.from_tracks(tracks, TIMES)
    assert np.allclose(scene.heading, 0.0)
    res = plan(CONFIG, VehicleParams(), ROUTE, 130.0, 11.5, 0.0, 11.5, 13.9, scene,
               np.array([1.0]), ())
    assert res.feasible and res.accel_mps2 == 0.0
    across = ScenePrediction(scene.xy, np.full_like(scene.heading, np.pi / 2), scene.length_m,
                             scene.width_m, scene.radius_m, scene.is_pedestrian, scene.mask)
    blocked = plan(CONFIG, VehicleParams(), ROUTE, 130.0, 11.5, 0.0, 11.5, 13.9, across,
                   np.array([1.0]), ())
    assert blocked.accel_mps2 < 0.0
