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
from marl_social.sim.road_map import Route


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
    if name != "map_scene":  # a scene drawn by hand
        assert all(lane.width_m == LANE_WIDTH_M for lane in layout.road_map.lanes)
    else:  # a real map's lanes are as wide as their bounds
        assert all(0.0 < lane.width_m < 20.0 for lane in layout.road_map.lanes)
    # every vehicle starts on the centreline of a lane, on its own route, heading along it
    lane_routes = [Route(lane.centerline) for lane in layout.road_map.lanes]
    for spec in layout.agents:
        if spec.kind == "vehicle":
            xy, heading = spec.initial_state[:2], spec.initial_state[2]
            offsets = [abs(route.project(xy)[1]) for route in lane_routes]
            assert min(offsets) < 1e-9, f"{spec.name} starts off every lane centreline"
            _, lateral, route_heading = layout.road_map.routes[spec.name].project(xy)
            assert abs(lateral) < 1e-9
            assert abs(np.angle(np.exp(1j * (heading - route_heading)))) < 1e-9
