"""A driver expects a vehicle that must give way to stop before the zone when it comfortably can
(models/yield_expectation.py), on the T-intersection's map: the robot's stem approach yields to
the eastbound lane."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.models.yield_expectation import YieldExpectation
from marl_social.scenarios import make_scenario
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.signal_rules import COMFORTABLE_DECEL_MPS2

CAR = VehicleParams()
TIMES = np.arange(1, 13) * 0.25  # (T,) [s]
LANE_EDGE_Y_M = -3.5  # the eastbound lane's south edge: the zones' south side [m]
STEM_X_M = 1.75  # the stem's northbound lane centre [m]


@pytest.fixture(scope="module")
def expectation():
    layout = make_scenario("t_intersection", hidden_vehicle="near").build(
        np.random.default_rng(0))
    return YieldExpectation(layout.road_map)


def _northbound(front_gap_m: float, speed_mps: float, x_m: float = STEM_X_M) -> tuple:
    """A car in the stem heading north, its front front_gap_m short of the lane (one object)."""
    y = LANE_EDGE_Y_M - front_gap_m - 0.5 * CAR.length_m
    return (np.array([[x_m, y]]), np.array([[0.0, speed_mps]]), np.array([0.5 * np.pi]),
            np.array([CAR.length_m]), np.array([CAR.width_m]), np.array([False]))


def _constant_velocity(xy, velocity) -> np.ndarray:
    return xy[:, None, :] + velocity[:, None, :] * TIMES[None, :, None]


@pytest.mark.parametrize("front_gap_m, speed_mps", [(2.0, 1.9), (0.5, 1.0), (3.0, 4.0)])
def test_a_yielding_car_that_can_stop_comfortably_is_expected_to_stop_at_the_lane(
        expectation, front_gap_m, speed_mps):
    """It decelerates uniformly at v^2 / 2d (<= the comfortable 3 m/s^2) and rests with its
    front at the lane's edge, never in the lane."""
    obj = _northbound(front_gap_m, speed_mps)
    gap = expectation.stop_distance_m(*obj)
    assert gap[0] == pytest.approx(front_gap_m)
    pred = expectation.predict_xy(*obj, TIMES)[0]
    front_y = pred[:, 1] + 0.5 * CAR.length_m
    assert front_y.max() == pytest.approx(LANE_EDGE_Y_M, abs=1e-9)
    assert np.all(np.diff(front_y) >= -1e-12) and np.allclose(pred[:, 0], STEM_X_M)
    decel = speed_mps ** 2 / (2.0 * front_gap_m)
    t_stop = speed_mps / decel
    early = TIMES < t_stop
    expected = obj[0][0, 1] + speed_mps * TIMES - 0.5 * decel * TIMES ** 2
    np.testing.assert_allclose(pred[early, 1], expected[early])
    assert decel <= COMFORTABLE_DECEL_MPS2


@pytest.mark.parametrize("front_gap_m, speed_mps", [(2.0, 5.0), (0.5, 2.0), (-1.0, 1.5)])
def test_a_car_that_cannot_stop_comfortably_or_is_in_the_lane_is_taken_to_go(
        expectation, front_gap_m, speed_mps):
    """Needing more than 3 m/s^2, or with its front already in the lane, it is predicted at
    constant velocity (the same bits)."""
    obj = _northbound(front_gap_m, speed_mps)
    np.testing.assert_array_equal(expectation.predict_xy(*obj, TIMES),
                                  _constant_velocity(obj[0], obj[1]))


def test_traffic_with_the_right_of_way_pedestrians_and_cars_heading_away_keep_going(
        expectation):
    """An eastbound car (the priority lane), a pedestrian walking north in the stem, a car
    leaving southwards and one at rest: constant velocity, bit for bit."""
    xy = np.array([[-20.0, -1.75], [STEM_X_M, -8.0], [-1.75, -8.0], [STEM_X_M, -9.0]])
    velocity = np.array([[11.0, 0.0], [0.0, 1.5], [0.0, -6.0], [0.0, 0.05]])
    heading = np.array([0.0, 0.5 * np.pi, -0.5 * np.pi, 0.5 * np.pi])
    args = (xy, velocity, heading, np.full(4, CAR.length_m), np.full(4, CAR.width_m),
            np.array([False, True, False, False]))
    assert np.all(np.isinf(expectation.stop_distance_m(*args)))
    np.testing.assert_array_equal(expectation.predict_xy(*args, TIMES),
                                  _constant_velocity(xy, velocity))


def test_a_side_of_the_car_meeting_the_zone_counts(expectation):
    """A car whose centre line passes just east of the merge zone but whose left side meets it
    is expected to stop: its sides' rays count, not only its centre's."""
    east_edge = max(z.polygon[:, 0].max() for z in expectation.road_map.conflict_zones)
    obj = _northbound(2.0, 1.5, x_m=east_edge + 0.4 * CAR.width_m)
    assert expectation.stop_distance_m(*obj)[0] == pytest.approx(2.0)
    obj = _northbound(2.0, 1.5, x_m=east_edge + 0.6 * CAR.width_m)
    assert np.isinf(expectation.stop_distance_m(*obj)[0])


def test_a_map_without_conflict_zones_predicts_constant_velocity():
    layout = make_scenario("occluded_crosswalk").build(np.random.default_rng(0))
    expectation = YieldExpectation(layout.road_map)
    assert not expectation.applies
    obj = _northbound(2.0, 1.9)
    np.testing.assert_array_equal(expectation.predict_xy(*obj, TIMES),
                                  _constant_velocity(obj[0], obj[1]))


def test_a_non_positive_deceleration_is_refused(expectation):
    with pytest.raises(ValueError, match="decel_mps2 must be > 0"):
        YieldExpectation(expectation.road_map, decel_mps2=0.0)


@settings(max_examples=60, deadline=None)
@given(x=st.floats(-8.0, 16.0), y=st.floats(-30.0, -5.0), heading=st.floats(0.2, 2.9),
       speed=st.floats(0.0, 14.0))
def test_a_prediction_never_speeds_up_turns_or_enters_the_zone_it_stops_for(
        expectation, x, y, heading, speed):
    """Any car south of the main road: its prediction moves along its velocity, never faster
    than constant velocity; if it is expected to stop, its footprint never enters a zone."""
    velocity = speed * np.array([[np.cos(heading), np.sin(heading)]])
    obj = (np.array([[x, y]]), velocity, np.array([heading]), np.array([CAR.length_m]),
           np.array([CAR.width_m]), np.array([False]))
    pred = expectation.predict_xy(*obj, TIMES)[0]
    cv = _constant_velocity(obj[0], velocity)[0]
    travelled = np.linalg.norm(pred - obj[0], axis=1)
    assert np.all(travelled <= np.linalg.norm(cv - obj[0], axis=1) + 1e-9)
    assert np.all(np.diff(travelled) >= -1e-9)
    if not np.array_equal(pred, cv):
        gap = expectation.stop_distance_m(*obj)[0]
        assert travelled.max() <= gap + 1e-9
        assert speed ** 2 <= 2.0 * COMFORTABLE_DECEL_MPS2 * gap + 1e-9
