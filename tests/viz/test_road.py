"""The static map's markings: crosswalk stripes inside the crosswalk, road edges and dividers."""

from __future__ import annotations

import numpy as np

from marl_social.scenarios import make_scenario
from marl_social.viz.road import crosswalk_stripes, lane_markings
from marl_social.viz.style import CROSSWALK_PERIOD_M, CROSSWALK_STRIPE_M


def _road_map():
    return make_scenario("occluded_crosswalk").build(np.random.default_rng(0)).road_map


def test_crosswalk_stripes_lie_inside_the_crosswalk_one_period_apart():
    crosswalk = _road_map().crosswalks[0]
    stripes = crosswalk_stripes(crosswalk)
    assert len(stripes) >= 2
    for stripe in stripes:
        assert stripe.shape == (4, 2)
        assert crosswalk.contains(stripe, margin_m=1e-9).all()
        assert np.linalg.norm(stripe[1] - stripe[0]) <= CROSSWALK_STRIPE_M + 1e-9
    starts = np.array([s[0] for s in stripes])
    gaps = np.linalg.norm(np.diff(starts, axis=0), axis=1)
    assert np.allclose(gaps, CROSSWALK_PERIOD_M)


def test_lane_markings_split_road_edges_from_dividers():
    road_map = _road_map()
    solid, dashed = lane_markings(road_map)
    assert len(solid) == 2  # two lanes side by side: two road edges, one dashed divider
    assert len(dashed) > 1
    assert all(piece.shape[1] == 2 for piece in solid + dashed)


def test_stop_lines_and_signal_heads_are_drawn_on_the_map():
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.figure import Figure

    from marl_social.viz.road import draw_road_map, signal_head_squares

    road_map = make_scenario("signalized_intersection").build(np.random.default_rng(0)).road_map
    ax = Figure().add_subplot()
    draw_road_map(ax, road_map)
    lines = [np.asarray(seg) for c in ax.collections if isinstance(c, LineCollection)
             for seg in c.get_segments()]
    for stop in road_map.stop_lines:
        assert any(seg.shape == (2, 2) and np.allclose(seg, stop.segment) for seg in lines)
    squares = [np.asarray(p.vertices)[:4] for c in ax.collections
               if isinstance(c, PolyCollection) for p in c.get_paths()]
    for square in signal_head_squares(road_map):
        assert any(np.allclose(v, square) for v in squares)
