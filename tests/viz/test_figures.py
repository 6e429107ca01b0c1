"""The paper-style episode figure: a readable PNG, and shape errors that name the array."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

import marl_social
from marl_social.viz.figures import EpisodeArrays, plot_episode
from tests.viz.pixels import green_pixels, red_pixels


def _episode(steps: int = 25):
    env = marl_social.parallel_env()
    env.reset(seed=0)
    times, states, active, visible = [], [], [], []
    for _ in range(steps):
        w = env.world
        times.append(w.time_s)
        states.append(w.state.copy())
        active.append(w.active.copy())
        visible.append(env.last_fov.visible.copy())
        env.step({a: np.zeros(2) for a in env.agents})
    roles = [env.agent_specs[a].role for a in env.possible_agents]
    return (env.road_map, env.possible_agents, roles, np.array(times), np.array(states),
            np.array(active), np.array(visible))


def test_plot_episode_writes_a_readable_png(tmp_path):
    road_map, names, roles, times, states, active, visible = _episode()
    belief = np.linspace(0.0, 1.0, len(times))
    path = plot_episode(road_map, EpisodeArrays(names, roles, times, states, active, visible),
                        tmp_path / "figs" / "episode.png", title="test episode",
                        beliefs={"robot belief": belief})
    assert path.exists()
    with Image.open(path) as img:
        assert img.format == "PNG"
        assert img.size[0] >= 1000 and img.size[1] >= 700
        pixels = np.asarray(img.convert("RGB"))
    assert pixels.std() > 10.0
    assert red_pixels(pixels).sum() > 200  # robot boxes and its curves
    assert green_pixels(pixels).sum() > 20  # pedestrian dots


def test_plot_episode_rejects_inconsistent_shapes(tmp_path):
    road_map, names, roles, times, states, active, visible = _episode(5)
    with pytest.raises(ValueError, match="states"):
        plot_episode(road_map, EpisodeArrays(names, roles, times, states[:-1], active, visible),
                     tmp_path / "x.png")
    with pytest.raises(ValueError, match="belief"):
        plot_episode(road_map, EpisodeArrays(names, roles, times, states, active, visible),
                     tmp_path / "x.png", beliefs={"belief": np.zeros(3)})
