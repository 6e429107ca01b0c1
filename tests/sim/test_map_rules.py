"""Stop lines, conflict zones and route crossings of the static map."""

import numpy as np
import pytest

from marl_social.sim.road_map import ConflictZone, Lane, RoadMap, Route, StopLine


def test_route_crosses_a_stop_line_at_its_arc_length():
    route = Route([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])  # east, then north
    np.testing.assert_allclose(route.segment_crossings([[4.0, -2.0], [4.0, 2.0]]), [4.0])
    np.testing.assert_allclose(route.segment_crossings([[8.0, 6.0], [12.0, 6.0]]), [16.0])
    assert route.segment_crossings([[20.0, -1.0], [20.0, 1.0]]).size == 0  # beyond its end
    with pytest.raises(ValueError, match="segment"):
        route.segment_crossings([[0.0, 0.0], [np.nan, 1.0]])


def test_conflict_zone_contains_points_and_checks_its_lanes():
    zone = ConflictZone(np.array([[0.0, 0.0], [0.0, 4.0], [4.0, 4.0], [4.0, 0.0]]), "box", (0,))
    inside = zone.contains(np.array([[2.0, 2.0], [4.5, 2.0], [-0.2, 1.0]]), margin_m=0.3)
    assert inside.tolist() == [True, False, True]
    lane = Lane(np.array([[-5.0, 2.0], [10.0, 2.0]]), 3.5, "eastbound")
    RoadMap(lanes=(lane,), crosswalks=(), static_polygons=(), conflict_zones=(zone,))
    with pytest.raises(ValueError, match="priority lanes"):
        RoadMap(lanes=(), crosswalks=(), static_polygons=(), conflict_zones=(zone,))


def test_stop_line_rejects_bad_kind_and_lane():
    with pytest.raises(ValueError, match="kind"):
        StopLine(np.array([[0.0, 0.0], [0.0, 1.0]]), kind="yield")
    line = StopLine(np.array([[0.0, 0.0], [0.0, 1.0]]), lane=3)
    with pytest.raises(ValueError, match="lane 3"):
        RoadMap(lanes=(), crosswalks=(), static_polygons=(), stop_lines=(line,))
