"""Demo caption: the legend and the robot's belief bar under each frame, grey once passed."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.colors import to_rgb

from marl_social.sim.road_map import Crosswalk
from marl_social.viz.overlay import (
    BAR_WIDTH_PX,
    CAPTION_HEIGHT_PX,
    PASSED_COLOR,
    DemoCaption,
    caption_frames,
    crosswalk_ahead,
)
from marl_social.viz.style import BELIEF_COLORS

W = 1000


def _color_pixels(img: np.ndarray, color: str, tol: int = 12) -> np.ndarray:
    rgb = np.round(np.asarray(to_rgb(color)) * 255).astype(int)
    return (np.abs(img.astype(int) - rgb) <= tol).all(axis=-1)


def _bar_fill_px(strip: np.ndarray, color: str) -> int:
    """Longest unbroken run of the bar's colour on any row of the strip [px]."""
    best = 0
    for row in _color_pixels(strip, color):
        edges = np.flatnonzero(np.diff(np.concatenate([[0], row.astype(int), [0]])))
        if edges.size:
            best = max(best, int((edges[1::2] - edges[::2]).max()))
    return best


@pytest.fixture
def frame() -> np.ndarray:
    rng = np.random.default_rng(3)
    return rng.integers(0, 256, size=(120, W, 3), dtype=np.uint8)


def test_the_caption_goes_under_the_frame_and_leaves_it_untouched(frame):
    out = DemoCaption(W).add(frame, 0.4, "inferred")
    assert out.shape == (120 + CAPTION_HEIGHT_PX, W, 3) and out.dtype == np.uint8
    assert np.array_equal(out[:120], frame)
    assert out[120:].std() > 5.0  # the legend is drawn


@pytest.mark.parametrize("p", list(np.random.default_rng(7).uniform(0.05, 1.0, size=6)))
def test_the_bar_is_as_long_as_the_belief(p):
    strip = DemoCaption(W).strip(p, "inferred")
    assert _bar_fill_px(strip, BELIEF_COLORS[0]) == pytest.approx(p * BAR_WIDTH_PX, abs=4)
    assert _bar_fill_px(DemoCaption(W).strip(p, "sees"), BELIEF_COLORS[0]) == pytest.approx(
        p * BAR_WIDTH_PX, abs=4)


def test_after_the_crosswalk_the_bar_is_grey_and_without_a_belief_there_is_none():
    caption = DemoCaption(W)
    passed = caption.strip(0.6, "passed")
    assert _color_pixels(passed, BELIEF_COLORS[0]).sum() == 0
    assert _bar_fill_px(passed, PASSED_COLOR) == pytest.approx(0.6 * BAR_WIDTH_PX, abs=4)
    for empty in (caption.strip(None), caption.strip(float("nan"), "sees")):
        assert _color_pixels(empty, BELIEF_COLORS[0]).sum() == 0
        assert _bar_fill_px(empty, PASSED_COLOR) < 10  # anti-aliased text only
    # the strip differs with what it says: sees vs inferred
    assert np.any(caption.strip(0.5, "sees") != caption.strip(0.5, "inferred"))


def test_caption_errors_name_what_is_wrong(frame):
    caption = DemoCaption(W)
    with pytest.raises(ValueError, match="status"):
        caption.strip(0.5, "maybe")
    with pytest.raises(ValueError, match="p_pedestrian"):
        caption.strip(1.5)
    with pytest.raises(ValueError, match="frame"):
        caption.add(frame[:, :500])
    with pytest.raises(ValueError, match="roles"):
        DemoCaption(W, roles=("robot", "cyclist"))
    with pytest.raises(ValueError, match="width_px"):
        DemoCaption(8)


def test_caption_frames_follow_the_series_and_hold_the_last_value(frame):
    frames = [frame] * 4
    out = caption_frames(frames, p_pedestrian=[0.2, 0.9], perceived=[0.0, 1.0],
                         ahead=[True, True, False])
    assert len(out) == 4
    fills = [_bar_fill_px(f[120:], BELIEF_COLORS[0]) for f in out]
    assert fills[0] == pytest.approx(0.2 * BAR_WIDTH_PX, abs=4)
    assert fills[1] == pytest.approx(0.9 * BAR_WIDTH_PX, abs=4)
    assert fills[2] == fills[3] == 0  # passed: grey
    assert _bar_fill_px(out[3][120:], PASSED_COLOR) == pytest.approx(0.9 * BAR_WIDTH_PX, abs=4)
    assert caption_frames([]) == []


class _Map:
    def __init__(self, crosswalks):
        self.crosswalks = crosswalks


@pytest.mark.parametrize("heading", list(np.random.default_rng(11).uniform(-np.pi, np.pi, 5)))
def test_a_crosswalk_is_ahead_until_the_agent_is_past_its_far_edge(heading):
    rng = np.random.default_rng(int(1000 * (heading + 4)))
    center = rng.uniform(-50, 50, size=2)
    fwd = np.array([np.cos(heading), np.sin(heading)])
    crosswalk = Crosswalk(center=center, walk_heading_rad=heading + np.pi / 2, length_m=7.0,
                          width_m=4.0)
    along = np.linspace(-80.0, 30.0, 221)  # the agent's position along the road, crosswalk 0
    states = np.zeros((len(along), 1, 4))
    states[:, 0, :2] = center + along[:, None] * fwd
    states[:, 0, 2] = heading
    active = np.ones((len(along), 1), dtype=bool)
    ahead = crosswalk_ahead(states, active, _Map([crosswalk]), 0, margin_m=2.5)
    clear = np.abs(along - 4.5) > 1e-6  # exactly on the edge either answer is right
    assert np.array_equal(ahead[clear], (along < 2.0 + 2.5)[clear])
    active[-50:] = False
    assert not crosswalk_ahead(states, active, _Map([crosswalk]), 0)[-50:].any()
    assert not crosswalk_ahead(states, active, _Map([]), 0).any()
    with pytest.raises(ValueError, match="agent_index"):
        crosswalk_ahead(states, active, _Map([crosswalk]), 3)


def test_in_the_paper_scenario_the_robot_passes_the_crosswalk_once():
    from marl_social.evaluation.run import run_episode

    res = run_episode("occluded_crosswalk", seed=5, pedestrian="crossing", max_cycles=150)
    tr = res.trace
    robot = tr.names.index("robot_0")
    ahead = crosswalk_ahead(tr.states, tr.active, res.road_map, robot)
    assert ahead[0] and not ahead[-1]
    assert np.count_nonzero(np.diff(ahead.astype(int))) == 1
    switch = int(np.argmin(ahead))
    far_edge = res.road_map.crosswalks[0].center[0] + 0.5 * res.road_map.crosswalks[0].width_m
    assert tr.states[switch - 1, robot, 0] <= far_edge + 2.5 < tr.states[switch, robot, 0]
