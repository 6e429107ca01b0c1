"""Live frames draw each signal head in the colour it shows now."""

from __future__ import annotations

import numpy as np
from matplotlib.colors import to_rgb

import marl_social
from marl_social.viz.frames import Renderer
from marl_social.viz.style import SIGNAL_STATE_COLORS


def _pixel(renderer: Renderer, frame: np.ndarray, xy) -> np.ndarray:
    col, row = np.round(renderer.world_to_pixel(np.asarray([xy]))[0]).astype(int)
    return frame[row, col].astype(float) / 255.0


def test_every_head_is_drawn_in_the_state_it_shows():
    env = marl_social.parallel_env(scenario="signalized_intersection", max_cycles=400)
    env.reset(seed=0)
    heads = env.world.signal_heads
    shown = set()
    for _ in range(12):  # a few moments of the cycle
        states = env.world.signal_states()
        for head, state in zip(heads, states):
            x, y = head.position
            renderer = Renderer(env.world.road_map, width_px=200, height_px=200,
                                view=(x - 4.0, x + 4.0, y - 4.0, y + 4.0))
            frame = renderer.draw(env.world)
            renderer.close()
            np.testing.assert_allclose(_pixel(renderer, frame, head.position),
                                       to_rgb(SIGNAL_STATE_COLORS[state]), atol=0.02)
            shown.add(int(state))
        for _ in range(25):
            env.step({a: np.zeros(2) for a in env.agents})
            if not env.agents:
                break
        if not env.agents:
            break
    assert len(shown) >= 2  # the colour follows the state, not a constant
