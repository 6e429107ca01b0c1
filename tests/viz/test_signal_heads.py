"""Live frames draw each signal head in the colour it shows now."""

from __future__ import annotations

import numpy as np
from matplotlib.colors import to_rgb

import marl_social
from marl_social.viz.frames import Renderer
from marl_social.viz.style import SIGNAL_STATE_COLORS, FrameSize


def _pixel(renderer: Renderer, frame: np.ndarray, xy) -> np.ndarray:
    col, row = np.round(renderer.world_to_pixel(np.asarray([xy]))[0]).astype(int)
    return frame[row, col].astype(float) / 255.0


def test_every_head_is_drawn_in_the_state_it_shows():
    env = marl_social.parallel_env(scenario="signalized_intersection", max_cycles=400)
    env.reset(seed=0)
    heads = env.world.signal_heads
    renderers = [Renderer(env.world.road_map, size=FrameSize(200, 200),  # one per head
                          view=(x - 4.0, x + 4.0, y - 4.0, y + 4.0))
                 for x, y in (head.position for head in heads)]
    shown = set()
    try:
        for _ in range(12):  # a few moments of the cycle
            states = env.world.signal_states()
            for head, state, renderer in zip(heads, states, renderers):
                frame = renderer.draw(env.world)
                np.testing.assert_allclose(_pixel(renderer, frame, head.position),
                                           to_rgb(SIGNAL_STATE_COLORS[state]), atol=0.02)
                shown.add(int(state))
            for _ in range(25):
                env.step({a: np.zeros(2) for a in env.agents})
                if not env.agents:
                    break
            if not env.agents:
                break
    finally:
        for renderer in renderers:
            renderer.close()
    assert len(shown) >= 2  # the colour follows the state, not a constant


def test_paper_figure_shows_each_heads_state_over_time(tmp_path):
    """plot_episode(signal_states=...) adds one strip per head in the colour it shows; the
    left-turners' green arrow (then yellow) appears, a wrong shape is a clear error."""
    import pytest
    from matplotlib.image import imread

    from marl_social.evaluation.run import run_episode
    from marl_social.viz.figures import EpisodeArrays, plot_episode

    res = run_episode("signalized_intersection", seed=0, robot_planner="oracle",
                      phase="protected_left", phase_elapsed_s=8.0, max_cycles=30)
    tr = res.trace
    args = (res.road_map, EpisodeArrays.from_trace(tr))

    def count(path, state):
        img = imread(path)[..., :3]
        return int(np.all(np.abs(img - to_rgb(SIGNAL_STATE_COLORS[state])) < 0.02,
                          axis=-1).sum())

    plain = plot_episode(*args, tmp_path / "plain.png")
    strips = plot_episode(*args, tmp_path / "strips.png", signal_states=tr.signal_states)
    states = np.asarray(tr.signal_states)
    assert {0, 1, 2} <= set(states.ravel().tolist())  # red, yellow and green in this window
    for state in (0, 1, 2):
        assert count(strips, state) > count(plain, state) + 200, state
    with pytest.raises(ValueError, match="signal_states"):
        plot_episode(*args, tmp_path / "bad.png", signal_states=states[:, :2])
