"""Shared road helpers (marl_social/scenarios/roads.py) and the scenarios built from them."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.scenarios import SCENARIOS, make_scenario
from marl_social.scenarios.roads import (
    LANE_WIDTH_M,
    lane_centres_y,
    road_extent,
    straight_lane,
    straight_route,
)


def test_lane_centres_are_symmetric_and_one_lane_width_apart():
    np.testing.assert_array_equal(lane_centres_y(1), [0.0])
    np.testing.assert_array_equal(lane_centres_y(2), [-0.5 * LANE_WIDTH_M, 0.5 * LANE_WIDTH_M])
    y = lane_centres_y(4)
    np.testing.assert_allclose(np.diff(y), LANE_WIDTH_M)
    np.testing.assert_allclose(y, -y[::-1])


def test_straight_lane_route_and_extent():
    lane = straight_lane(-10.0, 90.0, 1.75)
    np.testing.assert_array_equal(lane.centerline, [[-10.0, 1.75], [90.0, 1.75]])
    assert lane.width_m == LANE_WIDTH_M
    route = straight_route("robot_0", -10.0, 90.0, 1.75)
    assert route.name == "robot_0"
    xy, heading = route.point_at(np.array([10.0]))
    np.testing.assert_allclose(xy, [[0.0, 1.75]])
    np.testing.assert_allclose(heading, [0.0])
    assert road_extent(-10.0, 90.0, 8.5, 4.0) == (-10.0, 90.0, -12.5, 12.5)


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_every_lane_of_every_scenario_has_the_shared_width(name):
    layout = make_scenario(name).build(np.random.default_rng(0))
    assert layout.road_map.lanes
    assert all(lane.width_m == LANE_WIDTH_M for lane in layout.road_map.lanes)
    # every vehicle starts on the centreline of a lane, its route along that lane
    lane_y = {float(lane.centerline[0, 1]) for lane in layout.road_map.lanes}
    for spec in layout.agents:
        if spec.kind == "vehicle":
            assert float(spec.initial_state[1]) in lane_y
            route_y = layout.road_map.routes[spec.name].point_at(np.array([0.0]))[0][0, 1]
            assert route_y == spec.initial_state[1]
