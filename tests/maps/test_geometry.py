"""Map geometry helpers (marl_social/maps/geometry.py)."""

import numpy as np

from marl_social.maps.geometry import extended_polyline, polyline_crossings


def test_a_lane_ending_on_a_stop_line_crosses_it_once_extended():
    line = np.array([[10.0, -2.0], [10.0, 2.0]])
    lane = np.array([[0.0, 0.0], [5.0, 0.1], [9.99, 0.0]])  # ends on the line, as drawn
    assert len(polyline_crossings(line, lane)) == 0
    longer = extended_polyline(lane, 0.5)
    assert len(polyline_crossings(line, longer)) == 1
    np.testing.assert_allclose(longer[1], lane[1])  # only the ends move
    np.testing.assert_allclose(np.hypot(*(longer[-1] - lane[-1])), 0.5)
    np.testing.assert_allclose(np.hypot(*(longer[0] - lane[0])), 0.5)
    assert longer[0, 0] < 0.0 and longer[-1, 0] > 10.0 > lane[-1, 0]  # along the end segments, outwards


def test_a_lane_stopping_short_of_the_line_does_not_cross_it():
    line = np.array([[10.0, -2.0], [10.0, 2.0]])
    lane = np.array([[0.0, 0.0], [9.0, 0.0]])
    assert len(polyline_crossings(line, extended_polyline(lane, 0.5))) == 0
